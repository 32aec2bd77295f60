// shaders/brdf_models.glsl against the CPU models: the same geometries and
// parameters through a compute shader, read back and compared.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/glm.hpp>
#include <random>
#include <vector>

#include "core/brdf/blinn_phong.h"
#include "core/base/draw_order.h"
#include "core/brdf/geometry.h"
#include "core/brdf/ggx.h"
#include "core/brdf/phong.h"
#include "core/gl/egl_context.h"
#include "core/gl/gl_api.h"
#include "core/gl/gl_objects.h"
#include "core/gl/shader_program.h"

namespace mvbrdf::brdf {
namespace {

// float against double: exp(ke ln h) with ke up to 200 loses ~ke x 1e-7.
constexpr double kRelativeTolerance = 1e-4;
constexpr double kAbsoluteTolerance = 1e-6;

// Model 3 in the probe: GGX held at this grazing support (Ggx::SpecularWithin).
constexpr double kProbeSupport = 0.3;

struct Case {  // one std430 record: 9 floats
  float n_dot_l, n_dot_v, n_dot_h, v_dot_h, r_dot_v, p0, p1, p2, model;
};

constexpr char kProbe[] = R"(
#include "brdf_models.glsl"
layout(local_size_x = 64) in;
struct Case { float n_dot_l, n_dot_v, n_dot_h, v_dot_h, r_dot_v, p0, p1, p2, model; };
layout(std430, binding = 0) readonly buffer Cases { Case cases[]; };
layout(std430, binding = 1) writeonly buffer Results { vec2 results[]; };
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= uint(cases.length())) return;
  Case c = cases[i];
  BrdfGeometry g = BrdfGeometry(c.n_dot_l, c.n_dot_v, c.n_dot_h, c.v_dot_h, c.r_dot_v);
  if (c.model == 0.0) results[i] = vec2(PhongSpecular(c.p0, c.p1, g), 1.0);
  else if (c.model == 1.0) results[i] = vec2(BlinnPhongSpecular(c.p0, c.p1, g), 1.0);
  else if (c.model == 2.0) results[i] = vec2(GgxSpecular(c.p0, c.p1, c.p2, 0.0, g), GgxDiffuseWeight(c.p2, g));
  else results[i] = vec2(GgxSpecular(c.p0, c.p1, c.p2, 0.3, g), GgxDiffuseWeight(c.p2, g));
}
)";

TEST(BrdfGlslTest, EveryModelMatchesTheCpu) {
  auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
  ASSERT_TRUE(context.ok()) << context.status();
  absl::StatusOr<gl::Program> program = gl::BuildProgram({{GL_COMPUTE_SHADER, "brdf_probe.comp", kProbe}});
  ASSERT_TRUE(program.ok()) << program.status();

  // Random geometries near and away from each lobe, three parameter sets a model.
  std::mt19937 rng(5);
  std::normal_distribution<double> normal;
  const auto upper = [&] {
    glm::dvec3 d = base::DrawVec3<glm::dvec3>([&] { return normal(rng); });
    d.z = std::abs(d.z) + 0.05;
    return glm::normalize(d);
  };
  const glm::dvec3 n(0, 0, 1);
  // Phong, Blinn-Phong, GGX, and GGX again held at kProbeSupport.
  const double parameters[4][3][3] = {{{0.2, 4.0, 0.0}, {0.05, 40.0, 0.0}, {1.5, 120.0, 0.0}},
                                      {{0.5, 16.0, 0.0}, {0.05, 160.0, 0.0}, {1.0, 1.0, 0.0}},
                                      {{0.04, 0.5, 25.0}, {0.9, 0.2, 1.0}, {0.5, 1.0, 6.0}},
                                      {{0.04, 0.5, 25.0}, {0.9, 0.2, 1.0}, {0.5, 1.0, 6.0}}};
  std::vector<Case> cases;
  std::vector<Geometry> geometries;
  for (int i = 0; i < 400; ++i) {
    const glm::dvec3 l = upper();
    const glm::dvec3 mirror = 2.0 * glm::dot(l, n) * n - l;
    // Half of them within ~0.2 rad of the mirror direction, half anywhere
    // (some below the horizon: n.v < 0).
    const glm::dvec3 v = i % 2 == 0 ? glm::normalize(mirror + 0.2 * base::DrawVec3<glm::dvec3>([&] { return normal(rng); }))
                                    : glm::normalize(base::DrawVec3<glm::dvec3>([&] { return normal(rng); }));
    const Geometry g = GeometryOf(n, l, v);
    for (int model = 0; model < 4; ++model) {
      for (const auto& p : parameters[model]) {
        cases.push_back({static_cast<float>(g.n_dot_l), static_cast<float>(g.n_dot_v), static_cast<float>(g.n_dot_h),
                         static_cast<float>(g.v_dot_h), static_cast<float>(g.r_dot_v), static_cast<float>(p[0]),
                         static_cast<float>(p[1]), static_cast<float>(p[2]), static_cast<float>(model)});
        geometries.push_back(g);
      }
    }
  }
  gl::Buffer in = gl::CreateBuffer(), out = gl::CreateBuffer();
  glNamedBufferStorage(in.id(), static_cast<GLsizeiptr>(cases.size() * sizeof(Case)), cases.data(), 0);
  glNamedBufferStorage(out.id(), static_cast<GLsizeiptr>(cases.size() * sizeof(glm::vec2)), nullptr, GL_MAP_READ_BIT);
  glUseProgram(program->id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, in.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, out.id());
  glDispatchCompute(static_cast<GLuint>((cases.size() + 63) / 64), 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  std::vector<glm::vec2> results(cases.size());
  glGetNamedBufferSubData(out.id(), 0, static_cast<GLsizeiptr>(results.size() * sizeof(glm::vec2)), results.data());
  ASSERT_EQ(glGetError(), static_cast<GLenum>(GL_NO_ERROR));

  int nonzero = 0;
  for (size_t i = 0; i < cases.size(); ++i) {
    // The CPU evaluated at the float geometry and parameters the GPU saw.
    Geometry g;
    g.n_dot_l = cases[i].n_dot_l;
    g.n_dot_v = cases[i].n_dot_v;
    g.n_dot_h = cases[i].n_dot_h;
    g.v_dot_h = cases[i].v_dot_h;
    g.r_dot_v = cases[i].r_dot_v;
    const double p[3] = {cases[i].p0, cases[i].p1, cases[i].p2};
    double specular = 0, weight = 1;
    switch (static_cast<int>(cases[i].model)) {
      case 0:
        specular = Phong::Specular(p, g, nullptr);
        break;
      case 1:
        specular = BlinnPhong::Specular(p, g, nullptr);
        break;
      case 2:
        specular = Ggx::Specular(p, g, nullptr);
        weight = Ggx::DiffuseWeight(p, g, nullptr);
        break;
      default:
        specular = Ggx::SpecularWithin(p, g, kProbeSupport);
        weight = Ggx::DiffuseWeight(p, g, nullptr);
    }
    if (specular > 1e-3) ++nonzero;
    EXPECT_NEAR(results[i].x, specular, kAbsoluteTolerance + kRelativeTolerance * std::abs(specular))
        << "case " << i << " model " << cases[i].model;
    EXPECT_NEAR(results[i].y, weight, kAbsoluteTolerance + kRelativeTolerance * std::abs(weight)) << "case " << i;
  }
  // Most lobes were probed where they are not negligible, and the support
  // held some of the GGX lobes (model 3 differs from model 2 there).
  int held = 0;
  for (size_t i = 0; i < cases.size(); ++i) {
    if (cases[i].model == 3.0f && std::abs(results[i].x - results[i - 3].x) > 1e-3 * std::abs(results[i - 3].x)) ++held;
  }
  EXPECT_GT(held, 50);
  EXPECT_GT(nonzero, static_cast<int>(cases.size()) / 4);
}

}  // namespace
}  // namespace mvbrdf::brdf
