#include "core/render/solid_texture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/base/draw_order.h"
#include "core/gl/egl_context.h"
#include "core/gl/gl_objects.h"
#include "core/gl/shader_program.h"

namespace mvbrdf::render {
namespace {

// CPU and GPU evaluate the same float operations; they may differ by fused
// multiply-adds and pow/exp rounding only.
constexpr float kCpuGpuTolerance = 1e-4f;

TEST(SolidTextureTest, LatticeValuesAreDeterministicAndSpreadOverMinusOneToOne) {
  double sum = 0.0;
  float lo = 1.0f, hi = -1.0f;
  int count = 0;
  for (int x = -10; x < 10; ++x) {
    for (int y = -10; y < 10; ++y) {
      for (int z = -10; z < 10; ++z) {
        const float v = LatticeValue(x, y, z);
        ASSERT_GE(v, -1.0f);
        ASSERT_LE(v, 1.0f);
        EXPECT_EQ(v, LatticeValue(x, y, z));
        lo = std::min(lo, v);
        hi = std::max(hi, v);
        sum += v;
        ++count;
      }
    }
  }
  EXPECT_NEAR(sum / count, 0.0, 0.05);
  EXPECT_LT(lo, -0.99f);
  EXPECT_GT(hi, 0.99f);
  EXPECT_NE(LatticeValue(0, 0, 0), LatticeValue(1, 0, 0));
  EXPECT_NE(LatticeValue(1, 0, 0), LatticeValue(0, 1, 0));
  EXPECT_NE(LatticeValue(0, 1, 0), LatticeValue(0, 0, 1));
}

TEST(SolidTextureTest, NoiseInterpolatesTheLatticeContinuously) {
  EXPECT_EQ(ValueNoise({3, -2, 7}), LatticeValue(3, -2, 7));
  EXPECT_EQ(ValueNoise({-1, 0, 0}), LatticeValue(-1, 0, 0));
  // Halfway along x between two lattice points: smoothstep weight 1/2.
  EXPECT_NEAR(ValueNoise({0.5f, 0, 0}), 0.5f * (LatticeValue(0, 0, 0) + LatticeValue(1, 0, 0)), 1e-6f);
  // Continuous across a cell face.
  EXPECT_NEAR(ValueNoise({0.9999f, 0.3f, 0.2f}), ValueNoise({1.0001f, 0.3f, 0.2f}), 1e-3f);
}

TEST(SolidTextureTest, ZeroAmplitudeIsTheBaseAndResultIsClamped) {
  SolidTextureParams params;
  params.base = {0.2f, 0.4f, 0.6f};
  const glm::vec3 kd = EvaluateSolidTexture(params, {1.3f, -4.2f, 0.7f});
  EXPECT_EQ(kd, params.base);
  params.base = glm::vec3(0.9f);
  params.amplitude = 10.0f;
  for (float x = 0.0f; x < 5.0f; x += 0.37f) {
    const glm::vec3 v = EvaluateSolidTexture(params, {x, 0.5f * x, -x});
    EXPECT_GE(std::min({v.x, v.y, v.z}), 0.0f);
    EXPECT_LE(std::max({v.x, v.y, v.z}), 1.0f);
  }
}

// The GLSL twin (shaders/solid_texture.glsl) evaluated in a full-screen pass,
// one point per pixel, read back and compared with the C++.
TEST(SolidTextureTest, GpuMatchesCpu) {
  auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
  ASSERT_TRUE(context.ok()) << context.status();

  constexpr int kWidth = 64, kHeight = 64;
  std::vector<glm::vec4> points(kWidth * kHeight);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coordinate(-60.0f, 60.0f);
  for (size_t i = 0; i < points.size(); ++i) {
    points[i] = glm::vec4(base::DrawVec3<glm::vec3>([&] { return coordinate(rng); }), 0.0f);
    if (i % 8 == 0) points[i] = glm::floor(points[i]);  // lattice points: exact hash comparison
  }
  SolidTextureParams params;
  params.base = {0.55f, 0.35f, 0.8f};
  params.amplitude = 0.7f;
  params.frequency = 2.3f;
  params.offset = {0.25f, -1.5f, 3.0f};

  const std::string vertex =
      "void main() {\n"
      "  vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);\n"
      "  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);\n"
      "}\n";
  const std::string fragment =
      "#include \"solid_texture.glsl\"\n"
      "layout(std430, binding = 0) readonly buffer Points { vec4 points[]; };\n"
      "layout(location = 0) uniform int u_width;\n"
      "layout(location = 1) uniform vec3 u_base;\n"
      "layout(location = 2) uniform float u_amplitude;\n"
      "layout(location = 3) uniform float u_frequency;\n"
      "layout(location = 4) uniform vec3 u_offset;\n"
      "out vec4 color;\n"
      "void main() {\n"
      "  ivec2 pixel = ivec2(gl_FragCoord.xy);\n"
      "  vec3 p = points[pixel.y * u_width + pixel.x].xyz;\n"
      "  color = vec4(ValueNoise(p), EvaluateSolidTexture(u_base, u_amplitude, u_frequency, u_offset, p));\n"
      "}\n";
  absl::StatusOr<gl::Program> program = gl::BuildProgram({{GL_VERTEX_SHADER, "solid_texture_probe.vert", vertex},
                                                          {GL_FRAGMENT_SHADER, "solid_texture_probe.frag", fragment}});
  ASSERT_TRUE(program.ok()) << program.status();
  glProgramUniform1i(program->id(), 0, kWidth);
  glProgramUniform3f(program->id(), 1, params.base.x, params.base.y, params.base.z);
  glProgramUniform1f(program->id(), 2, params.amplitude);
  glProgramUniform1f(program->id(), 3, params.frequency);
  glProgramUniform3f(program->id(), 4, params.offset.x, params.offset.y, params.offset.z);

  gl::Buffer buffer = gl::CreateBuffer();
  glNamedBufferStorage(buffer.id(), static_cast<GLsizeiptr>(points.size() * sizeof(glm::vec4)), points.data(), 0);
  gl::Renderbuffer color = gl::CreateRenderbuffer();
  glNamedRenderbufferStorage(color.id(), GL_RGBA32F, kWidth, kHeight);
  gl::Framebuffer framebuffer = gl::CreateFramebuffer();
  glNamedFramebufferRenderbuffer(framebuffer.id(), GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color.id());
  ASSERT_TRUE(gl::CheckFramebufferComplete(framebuffer, "probe target").ok());
  gl::VertexArray vertex_array = gl::CreateVertexArray();

  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer.id());
  glViewport(0, 0, kWidth, kHeight);
  glDisable(GL_DEPTH_TEST);
  glUseProgram(program->id());
  glBindVertexArray(vertex_array.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, buffer.id());
  glDrawArrays(GL_TRIANGLES, 0, 3);
  std::vector<glm::vec4> result(points.size());
  glReadPixels(0, 0, kWidth, kHeight, GL_RGBA, GL_FLOAT, result.data());
  ASSERT_TRUE(gl::CheckGlError("probe pass").ok());

  float max_noise_error = 0.0f, max_kd_error = 0.0f, max_lattice_error = 0.0f;
  for (size_t i = 0; i < points.size(); ++i) {
    const glm::vec3 p(points[i]);
    const float noise_error = std::abs(result[i].x - ValueNoise(p));
    max_noise_error = std::max(max_noise_error, noise_error);
    if (i % 8 == 0) max_lattice_error = std::max(max_lattice_error, noise_error);
    const glm::vec3 kd = EvaluateSolidTexture(params, p);
    max_kd_error = std::max(
        {max_kd_error, std::abs(result[i].y - kd.x), std::abs(result[i].z - kd.y), std::abs(result[i].w - kd.z)});
  }
  EXPECT_LT(max_noise_error, kCpuGpuTolerance);
  EXPECT_LT(max_kd_error, kCpuGpuTolerance);
  EXPECT_EQ(max_lattice_error, 0.0f);  // the integer hash is bit-exact
}

}  // namespace
}  // namespace mvbrdf::render
