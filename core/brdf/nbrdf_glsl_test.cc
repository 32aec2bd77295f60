// shaders/nbrdf.glsl against NeuralBrdf::Evaluate: several materials in one
// weight buffer, random directions (anywhere, and near the mirror direction
// where the mirror-like materials peak) through a compute shader, read back
// and compared.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <glm/glm.hpp>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "core/brdf/nbrdf.h"
#include "core/base/draw_order.h"
#include "core/gl/egl_context.h"
#include "core/gl/gl_api.h"
#include "core/gl/gl_objects.h"
#include "core/gl/shader_program.h"

namespace mvbrdf::brdf {
namespace {

// float against double. The logits a3 = a2 W3 + b3 are sums of 21 products
// of magnitude up to ~10, so float rounding leaves an absolute error of
// ~1e-6 in a3 and hence a relative one in exp(a3) = 1 + rho: the error of rho
// scales with 1 + rho, not rho (where rho << 1, exp(a3) - 1 cancels too).
// Measured over the 6000 cases below (llvmpipe): |GLSL - CPU| / (1 + rho) at
// most 1.9e-6; relative where rho > 0.01 at most 2.0e-5.
constexpr double kRelativeTolerance = 1e-4;
constexpr double kAbsoluteTolerance = 1e-5;  // 1/sr

struct Case {    // one std430 record: 8 floats
  glm::vec4 wi;  // w: the material's index in the weight buffer
  glm::vec4 wo;
};

constexpr char kProbe[] = R"(
#define NBRDF_WEIGHTS_BINDING 2
#include "nbrdf.glsl"
layout(local_size_x = 64) in;
struct Case { vec4 wi, wo; };
layout(std430, binding = 0) readonly buffer Cases { Case cases[]; };
layout(std430, binding = 1) writeonly buffer Results { vec4 results[]; };
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= uint(cases.length())) return;
  Case c = cases[i];
  int material = int(c.wi.w);
  results[i] = vec4(material == 0 ? NbrdfEval(c.wi.xyz, c.wo.xyz) : NbrdfEvalMaterial(material, c.wi.xyz, c.wo.xyz),
                    0.0);
}
)";

TEST(NbrdfGlslTest, MatchesTheCpu) {
  const std::filesystem::path json = std::filesystem::path(MVBRDF_SHARED_DATA_DIR) / "merl_nbrdf/merl_nbrdf.json";
  // Like the other tests on ../shared/data, skipped where there is none.
  if (!std::filesystem::exists(json)) GTEST_SKIP() << "shared test data not found: " << json;
  const auto materials = LoadNeuralBrdfs(json);
  ASSERT_TRUE(materials.ok()) << materials.status();
  const std::vector<std::string> names = {"chrome",      "blue-acrylic", "white-fabric", "gold-metallic-paint",
                                          "red-plastic", "pink-felt"};
  std::vector<float> weights;
  for (const std::string& name : names) {
    const std::vector<float> w = materials->at(name).GlslWeights();
    weights.insert(weights.end(), w.begin(), w.end());
  }

  auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
  ASSERT_TRUE(context.ok()) << context.status();
  absl::StatusOr<gl::Program> program = gl::BuildProgram({{GL_COMPUTE_SHADER, "nbrdf_probe.comp", kProbe}});
  ASSERT_TRUE(program.ok()) << program.status();

  std::mt19937 rng(13);
  std::normal_distribution<double> normal;
  const auto upper = [&] {
    while (true) {
      glm::dvec3 d = base::DrawVec3<glm::dvec3>([&] { return normal(rng); });
      d.z = std::abs(d.z);
      if (glm::length(d) > 1e-3 && d.z > 0.02 * glm::length(d)) return glm::normalize(d);
    }
  };
  std::vector<Case> cases;
  for (size_t m = 0; m < names.size(); ++m) {
    for (int i = 0; i < 1000; ++i) {
      const glm::dvec3 wi = upper();
      // Half within ~0.1 rad of the mirror direction, half anywhere above.
      glm::dvec3 wo =
          i % 2 == 0
              ? glm::normalize(glm::dvec3(-wi.x, -wi.y, wi.z) + 0.1 * base::DrawVec3<glm::dvec3>([&] { return normal(rng); }))
              : upper();
      if (wo.z < 0.02) wo = upper();
      cases.push_back({glm::vec4(glm::vec3(wi), static_cast<float>(m)), glm::vec4(glm::vec3(wo), 0.0f)});
    }
  }

  gl::Buffer in = gl::CreateBuffer(), weight_buffer = gl::CreateBuffer(), out = gl::CreateBuffer();
  glNamedBufferStorage(in.id(), static_cast<GLsizeiptr>(cases.size() * sizeof(Case)), cases.data(), 0);
  glNamedBufferStorage(weight_buffer.id(), static_cast<GLsizeiptr>(weights.size() * sizeof(float)), weights.data(), 0);
  glNamedBufferStorage(out.id(), static_cast<GLsizeiptr>(cases.size() * sizeof(glm::vec4)), nullptr, GL_MAP_READ_BIT);
  glUseProgram(program->id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, in.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, out.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, weight_buffer.id());
  glDispatchCompute(static_cast<GLuint>((cases.size() + 63) / 64), 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  std::vector<glm::vec4> results(cases.size());
  glGetNamedBufferSubData(out.id(), 0, static_cast<GLsizeiptr>(results.size() * sizeof(glm::vec4)), results.data());
  ASSERT_EQ(glGetError(), static_cast<GLenum>(GL_NO_ERROR));

  double worst = 0.0, worst_relative = 0.0, largest = 0.0;
  size_t worst_case = 0;
  for (size_t i = 0; i < cases.size(); ++i) {
    // The CPU at the float directions the GPU saw.
    const int m = static_cast<int>(cases[i].wi.w);
    const glm::dvec3 rho =
        materials->at(names[m]).Evaluate(glm::dvec3(glm::vec3(cases[i].wi)), glm::dvec3(glm::vec3(cases[i].wo)));
    for (int c = 0; c < 3; ++c) {
      const double error = std::abs(results[i][c] - rho[c]);
      const double scaled = error / (1.0 + rho[c]);
      if (scaled > worst) {
        worst = scaled;
        worst_case = i;
      }
      if (rho[c] > 1e-2) worst_relative = std::max(worst_relative, error / rho[c]);
      largest = std::max(largest, rho[c]);
      EXPECT_LE(error, kRelativeTolerance * rho[c] + kAbsoluteTolerance)
          << names[m] << " case " << i << " channel " << c << ": GLSL " << results[i][c] << ", CPU " << rho[c];
    }
  }
  std::cout << "GLSL against CPU over " << cases.size() << " cases: worst |error| / (1 + rho) " << worst << " (case "
            << worst_case << ", " << names[static_cast<int>(cases[worst_case].wi.w)]
            << "), worst relative where rho > 0.01: " << worst_relative << ", largest rho " << largest << "\n";
  // The mirror-like materials were probed near their peaks.
  EXPECT_GT(largest, 100.0);
}

}  // namespace
}  // namespace mvbrdf::brdf
