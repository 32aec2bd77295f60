#include "core/fit/texel_normal_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace mvbrdf::fit {
namespace {

constexpr double kDegrees = 180.0 / 3.14159265358979323846;

double AngleDeg(const glm::dvec3& a, const glm::dvec3& b) {
  return std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0)) * kDegrees;
}

// Unit light directions over the upper hemisphere of the tangent frame.
std::vector<glm::dvec3> Lights(int count, bool coplanar) {
  std::vector<glm::dvec3> l;
  for (int k = 0; k < count; ++k) {
    const double phi = 2.0 * 3.14159265358979 * k / count, theta = 0.2 + 0.9 * (k % 5) / 5.0;
    l.push_back(coplanar
                    ? glm::dvec3(std::sin(theta) * (k % 2 ? 1 : -1), 0.0, std::cos(theta))
                    : glm::dvec3(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)));
  }
  return l;
}

// A Lambertian texel with a glossy lobe about the mirror direction of view
// v = z: model_c = kd_c max(0, m.l) + ks (max(0, R(l).v))^ke, one light per
// observation, intensity 1.
struct Texel {
  glm::dvec3 m, kd;
  double ks = 0.0, ke = 20.0;
  double Diffuse(const glm::dvec3& n, const glm::dvec3& l) const { return std::max(0.0, glm::dot(n, l)); }
  double Specular(const glm::dvec3& n, const glm::dvec3& l) const {
    const double nl = glm::dot(n, l);
    if (!(nl > 0.0)) return 0.0;
    const glm::dvec3 r = 2.0 * nl * n - l;
    return ks * std::pow(std::max(0.0, r.z), ke);
  }
};

TEST(TexelNormalFitTest, TheClosedFormRecoversALambertianNormal) {
  const Texel truth{glm::normalize(glm::dvec3(0.3, -0.2, 1.0)), {0.5, 0.4, 0.3}};
  const glm::dvec3 cluster_kd(0.6, 0.48, 0.36);  // the texel is darker than its cluster, same colour
  NormalStereoSums sums(1);
  for (const glm::dvec3& l : Lights(24, false)) {
    double y = 0.0;
    for (int c = 0; c < 3; ++c) y += truth.kd[c] * truth.Diffuse(truth.m, l);
    if (!(truth.Diffuse(truth.m, l) > 0.0)) continue;
    sums.Add(0, 1.0, y, (cluster_kd.x + cluster_kd.y + cluster_kd.z) * l);
  }
  TexelNormalOptions options;
  options.prior_weight = 0.0;
  const NormalStereoSums::Solution s = sums.Solve(0, options);
  EXPECT_EQ(s.flags, 0);
  EXPECT_LT(AngleDeg(glm::dvec3(s.m), truth.m), 1e-4);
  // The prior pulls towards the mesh normal, a little for one observation's worth.
  options.prior_weight = 1.0;
  const double with_prior = AngleDeg(glm::dvec3(sums.Solve(0, options).m), truth.m);
  EXPECT_GT(with_prior, 1e-4);
  EXPECT_LT(with_prior, 2.0);
}

TEST(TexelNormalFitTest, TooFewOrCoplanarObservationsKeepTheMeshNormal) {
  TexelNormalOptions options;
  NormalStereoSums sums(2);
  for (const glm::dvec3& l : Lights(4, false)) sums.Add(0, 1.0, l.z, l);
  for (const glm::dvec3& l : Lights(24, true)) sums.Add(1, 1.0, l.z, l);
  EXPECT_EQ(sums.Solve(0, options).flags, kNormalFewObservations);
  EXPECT_EQ(sums.Solve(1, options).flags, kNormalCoplanarLights);
  EXPECT_EQ(sums.Solve(1, options).m, glm::vec3(0.0f, 0.0f, 1.0f));
}

TEST(TexelNormalFitTest, GaussNewtonStepsConvergeWithASpecularLobe) {
  // The closed form starts from the diffuse part with the lobe read at the
  // mesh normal (as the pipeline does); the steps model the lobe.
  Texel truth{glm::normalize(glm::dvec3(-0.25, 0.35, 1.0)), {0.45, 0.35, 0.25}, 0.6, 30.0};
  const std::vector<glm::dvec3> lights = Lights(40, false);
  TexelNormalOptions options;
  options.prior_weight = 0.0;
  NormalStereoSums start(1);
  for (const glm::dvec3& l : lights) {
    double y = 0.0;
    for (int c = 0; c < 3; ++c) {
      y += truth.kd[c] * truth.Diffuse(truth.m, l) + truth.Specular(truth.m, l) - truth.Specular({0, 0, 1}, l);
    }
    start.Add(0, 1.0, y, 1.5 * l);
  }
  glm::dvec3 m(start.Solve(0, options).m), kd(0.5, 0.5, 0.5);
  const double closed_form_error = AngleDeg(m, truth.m);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.002);
  double sigma = 0.0;
  for (int iteration = 0; iteration < 6; ++iteration) {
    const NormalTangentBasis basis(m);
    NormalGaussNewtonSums sums(1);
    constexpr double kStep = 1e-4;
    for (const glm::dvec3& l : lights) {
      const auto model = [&](const glm::dvec3& n, int c, double kd_c) {
        return kd_c * truth.Diffuse(n, l) + truth.Specular(n, l);
      };
      std::array<std::array<double, 5>, 3> j{};
      glm::dvec3 res;
      for (int c = 0; c < 3; ++c) {
        const double at = model(m, c, kd[c]);
        res[c] = model(truth.m, c, truth.kd[c]) + noise(rng) - at;
        j[c][0] = (model(basis.At(kStep, 0.0), c, kd[c]) - at) / kStep;
        j[c][1] = (model(basis.At(0.0, kStep), c, kd[c]) - at) / kStep;
        j[c][2 + c] = truth.Diffuse(m, l);
      }
      sums.Add(0, j, res, glm::dvec3(1.0));
    }
    const NormalGaussNewtonSums::Step step = sums.Solve(0, basis, kd, glm::dvec3(0.5), options);
    ASSERT_TRUE(step.ok);
    m = basis.At(step.alpha, step.beta);
    kd = step.kd;
    sigma = step.sigma_deg;
  }
  EXPECT_LT(AngleDeg(m, truth.m), 0.2);
  EXPECT_GT(closed_form_error, 1.0) << "the lobe must matter for this test";
  EXPECT_NEAR(kd.x, truth.kd.x, 0.01);
  EXPECT_NEAR(kd.z, truth.kd.z, 0.01);
  // The reported uncertainty is of the size of the error noise makes.
  EXPECT_GT(sigma, 0.0);
  EXPECT_LT(sigma, 1.0);
}

TEST(TexelNormalFitTest, OptionsAreChecked) {
  TexelNormalOptions options;
  EXPECT_TRUE(options.Check().ok());
  options.max_tilt_deg = 95.0;
  EXPECT_EQ(options.Check().message(), "normals.max_tilt_deg: must be in (0, 90), got 95");
}

}  // namespace
}  // namespace mvbrdf::fit
