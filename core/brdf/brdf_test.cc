// The BRDF models against their definitions: analytic Jacobians against
// Ceres' numeric differentiation, hand-computed values, reciprocity, and the
// energy they reflect (integrated over the hemisphere of light directions).
#include <ceres/ceres.h>
#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/glm.hpp>
#include <random>
#include <vector>

#include "core/brdf/blinn_phong.h"
#include "core/base/draw_order.h"
#include "core/brdf/model.h"
#include "core/brdf/geometry.h"
#include "core/brdf/ggx.h"
#include "core/brdf/ggx_equivalent.h"
#include "core/brdf/phong.h"

namespace mvbrdf::brdf {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kJacobianPrecision = 1e-6;  // relative, against Ceres' central differences
constexpr double kValueTolerance = 1e-12;
// Of Albedo's midpoint rule (600 x 1200 directions): Blinn-Phong's lobe,
// normalised to integrate to exactly 1 seen along the normal, came to
// 1 + 3e-6.
constexpr double kQuadratureError = 1e-4;

glm::dvec3 RandomUpperDirection(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  while (true) {
    glm::dvec3 d = base::DrawVec3<glm::dvec3>([&] { return normal(rng); });
    d.z = std::abs(d.z);
    if (glm::length(d) > 1e-3 && d.z > 0.05 * glm::length(d)) return glm::normalize(d);
  }
}

// Residuals (Specular, DiffuseWeight) of model M at one geometry.
template <typename M>
class ModelCost : public ceres::SizedCostFunction<2, M::kNumParameters> {
 public:
  explicit ModelCost(const Geometry& geometry) : geometry_(geometry) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    double ds[M::kNumParameters], dw[M::kNumParameters];
    residuals[0] = M::Specular(parameters[0], geometry_, ds);
    residuals[1] = M::DiffuseWeight(parameters[0], geometry_, dw);
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      for (int k = 0; k < M::kNumParameters; ++k) {
        jacobians[0][k] = ds[k];
        jacobians[0][M::kNumParameters + k] = dw[k];
      }
    }
    return true;
  }

 private:
  Geometry geometry_;
};

struct JacobianProbe {
  double p0, p1;
  double spread;  // radians: how far v strays from l's mirror direction
  double p2 = Ggx::kDielectricRatio;  // GGX's f90_ratio
};

// Probed near each lobe (v within ~`spread` of l's mirror direction, so the
// specular term is not negligible): central differences of a term below
// ~1e-12 cannot resolve its derivatives, which GradientChecker's relative
// error then reports as wrong.
template <typename M>
void CheckJacobians(const std::vector<JacobianProbe>& probes) {
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  const glm::dvec3 n(0, 0, 1);
  int checked = 0;
  for (const JacobianProbe& probe : probes) {
    for (int i = 0; i < 40; ++i) {
      const glm::dvec3 l = RandomUpperDirection(rng);
      const glm::dvec3 mirror = 2.0 * glm::dot(l, n) * n - l;
      const glm::dvec3 v = glm::normalize(mirror + probe.spread * base::DrawVec3<glm::dvec3>([&] { return normal(rng); }));
      if (v.z < 0.05) continue;
      const Geometry geometry = GeometryOf(n, l, v);
      double p[3] = {probe.p0, probe.p1, probe.p2};
      // A derivative below the value's rounding (GGX's ratio where (1 - v.h)^5
      // is ~1e-13, near the mirror direction) cannot be resolved numerically.
      double ds[3] = {0.0, 0.0, 0.0};
      const double s = M::Specular(p, geometry, ds);
      bool resolvable = true;
      for (int k = 0; k < M::kNumParameters; ++k) {
        if (ds[k] != 0.0 && std::abs(ds[k] * p[k]) < 1e-7 * std::abs(s)) resolvable = false;
      }
      if (!resolvable) continue;
      ModelCost<M> cost(geometry);
      // GradientChecker differentiates by Ridders' method; from its default
      // first step (1e-2 relative) it settled on a wrong slope of the GGX
      // roughness (0.0056 where central differences of any step from 1e-2 to
      // 1e-6 give -0.00327).
      ceres::NumericDiffOptions numeric;
      numeric.ridders_relative_initial_step_size = 1e-4;
      const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
      ceres::GradientChecker checker(&cost, no_manifolds, numeric);
      ceres::GradientChecker::ProbeResults results;
      const double* blocks[] = {p};
      EXPECT_TRUE(checker.Probe(blocks, kJacobianPrecision, &results))
          << M::kName << " at " << p[0] << ", " << p[1] << ", n.l " << geometry.n_dot_l << " n.v " << geometry.n_dot_v
          << " n.h " << geometry.n_dot_h << " v.h " << geometry.v_dot_h << ": " << results.error_log;
      ++checked;
    }
  }
  EXPECT_GT(checked, 20 * static_cast<int>(probes.size()));
}

TEST(BrdfJacobianTest, PhongMatchesNumericDerivatives) {
  CheckJacobians<Phong>({{0.2, 4.0, 0.5}, {0.05, 40.0, 0.15}, {1.5, 0.5, 0.9}});
}

TEST(BrdfJacobianTest, BlinnPhongMatchesNumericDerivatives) {
  CheckJacobians<BlinnPhong>({{0.5, 16.0, 0.3}, {0.05, 160.0, 0.1}, {1.0, 1.0, 0.9}});
}

TEST(BrdfJacobianTest, GgxMatchesNumericDerivatives) {
  CheckJacobians<Ggx>({{0.04, 0.5, 0.5},
                       {0.9, 0.2, 0.15},
                       {0.5, 1.0, 0.9},
                       {0.02, 0.05, 0.01},
                       {0.3, 0.3, 0.9, 1.0},
                       {0.1, 0.6, 0.9, 4.0},
                       {0.01, 0.1, 0.2, 50.0}});
}

TEST(BrdfValueTest, HandComputedValues) {
  const glm::dvec3 n(0, 0, 1);
  // Light and camera along the normal: h = n, every cosine 1.
  const Geometry head_on = GeometryOf(n, n, n);
  const double phong[] = {0.3, 12.0};
  EXPECT_NEAR(Phong::Specular(phong, head_on, nullptr), 0.3, kValueTolerance);
  const double blinn[] = {0.5, 24.0};
  EXPECT_NEAR(BlinnPhong::Specular(blinn, head_on, nullptr),
              0.5 * 26.0 * 28.0 / (8.0 * kPi * (std::exp2(-12.0) + 24.0)), kValueTolerance);
  // GGX head on: D = 1 / (pi a^2), V = 1/4, F = F0.
  const double ggx[] = {0.04, 0.5, Ggx::kDielectricRatio};
  const double a = 0.25;
  EXPECT_NEAR(Ggx::Specular(ggx, head_on, nullptr), 0.04 / (4.0 * kPi * a * a), kValueTolerance);
  EXPECT_NEAR(Ggx::DiffuseWeight(ggx, head_on, nullptr), 0.96, kValueTolerance);
  // The ratio: head on F = F0 whatever it is; at grazing v.h -> 0, F -> F90 =
  // phi F0; a flat curve (phi 1) leaves no diffuse.
  const double flat[] = {0.04, 0.5, 1.0}, fourfold[] = {0.04, 0.5, 4.0};
  EXPECT_NEAR(Ggx::Specular(flat, head_on, nullptr), Ggx::Specular(ggx, head_on, nullptr), kValueTolerance);
  EXPECT_EQ(Ggx::DiffuseWeight(flat, head_on, nullptr), 0.0);
  EXPECT_NEAR(Ggx::DiffuseWeight(fourfold, head_on, nullptr), 0.75, kValueTolerance);
  {
    const double deg = kPi / 180.0;
    // Light and view 89.9 degrees apart from each other about n: v.h = cos 89.9 deg.
    const glm::dvec3 l(std::sin(89.9 * deg), 0, std::cos(89.9 * deg)), v(-l.x, 0, l.z);
    const Geometry grazing = GeometryOf(n, l, v);
    const double w = std::pow(1.0 - grazing.v_dot_h, 5.0);
    for (const double* p : {ggx, flat, fourfold}) {
      const double f = Ggx::Specular(p, grazing, nullptr) / Ggx::Specular(flat, grazing, nullptr) * p[0];
      EXPECT_NEAR(f, p[0] * (1.0 + (p[2] - 1.0) * w), 1e-12) << p[2];
    }
  }

  // The thesis's mirror lobe: l at 30 degrees, v at its mirror direction
  // rotated by 10 degrees in the plane: h = cos 10 degrees.
  const double deg = kPi / 180.0;
  const glm::dvec3 l(std::sin(30 * deg), 0, std::cos(30 * deg));
  const glm::dvec3 v(-std::sin(40 * deg), 0, std::cos(40 * deg));
  const Geometry g = GeometryOf(n, l, v);
  EXPECT_NEAR(g.r_dot_v, std::cos(10 * deg), 1e-12);
  EXPECT_NEAR(Phong::Specular(phong, g, nullptr), 0.3 * std::pow(std::cos(10 * deg), 12.0), kValueTolerance);
  // The half vector sits 5 degrees from n.
  EXPECT_NEAR(g.n_dot_h, std::cos(5 * deg), 1e-12);
  EXPECT_NEAR(g.v_dot_h, std::cos(35 * deg), 1e-12);

  // No light from below, nothing seen from below.
  const Geometry below = GeometryOf(n, glm::dvec3(0, 0, -1), n);
  EXPECT_EQ(Phong::Specular(phong, below, nullptr), 0.0);
  EXPECT_EQ(BlinnPhong::Specular(blinn, below, nullptr), 0.0);
  EXPECT_EQ(Ggx::Specular(ggx, below, nullptr), 0.0);
  const Geometry unseen = GeometryOf(n, n, glm::dvec3(0, 0, -1));
  EXPECT_EQ(BlinnPhong::Specular(blinn, unseen, nullptr), 0.0);
  EXPECT_EQ(Ggx::Specular(ggx, unseen, nullptr), 0.0);
}

// f_r = L / (n.l) per unit intensity: the specular BRDF.
template <typename M>
double Brdf(const double* p, const glm::dvec3& n, const glm::dvec3& l, const glm::dvec3& v) {
  const Geometry g = GeometryOf(n, l, v);
  return M::Specular(p, g, nullptr) / g.n_dot_l;
}

// SpecularWithin (the lobe as a reconstruction draws it): the plain lobe
// wherever V's denominator is at or above the support, and at the mirror
// direction towards grazing no longer rising faster than its Fresnel factor
// once below it; reciprocal like the plain lobe.
TEST(BrdfValueTest, GgxHeldAtItsGrazingSupport) {
  const double p[3] = {0.04, 0.1, 25.0};
  const double support = 0.2;  // s = 2 cos^2(theta) for a sharp lobe: theta ~ 71.6 deg
  const glm::dvec3 n(0, 0, 1);
  const auto mirror = [&](double theta) {
    const glm::dvec3 l(std::sin(theta), 0, std::cos(theta)), v(-std::sin(theta), 0, std::cos(theta));
    return GeometryOf(n, l, v);
  };
  for (double degrees : {0.0, 30.0, 60.0, 70.0}) {
    const Geometry g = mirror(degrees * kPi / 180.0);
    EXPECT_DOUBLE_EQ(Ggx::SpecularWithin(p, g, support), Ggx::Specular(p, g, nullptr)) << degrees;
    EXPECT_DOUBLE_EQ(Ggx::SpecularWithin(p, g, 0.0), Ggx::Specular(p, g, nullptr)) << degrees;
  }
  double previous_ratio = 0.0;
  for (double degrees : {75.0, 80.0, 85.0, 88.0}) {
    const Geometry g = mirror(degrees * kPi / 180.0);
    const double held = Ggx::SpecularWithin(p, g, support), plain = Ggx::Specular(p, g, nullptr);
    EXPECT_LT(held, plain) << degrees;
    // Held: n.l F D 0.5 / support, so held / (n.l F) is the same at every angle.
    const double fresnel = 1.0 + 24.0 * std::pow(1.0 - g.v_dot_h, 5.0);
    const double ratio = held / (g.n_dot_l * fresnel);
    if (previous_ratio > 0.0) {
      EXPECT_NEAR(ratio, previous_ratio, 1e-9 * ratio) << degrees;
    }
    previous_ratio = ratio;
  }
  // Reciprocal: swapping l and v changes nothing.
  const glm::dvec3 l = glm::normalize(glm::dvec3(0.9, 0.1, 0.15)), v = glm::normalize(glm::dvec3(-0.8, -0.2, 0.2));
  EXPECT_NEAR(Ggx::SpecularWithin(p, GeometryOf(n, l, v), support) / GeometryOf(n, l, v).n_dot_l,
              Ggx::SpecularWithin(p, GeometryOf(n, v, l), support) / GeometryOf(n, v, l).n_dot_l, 1e-12);
}

TEST(BrdfReciprocityTest, BlinnPhongAndGgxAreReciprocalPhongIsNot) {
  std::mt19937 rng(11);
  const glm::dvec3 n(0, 0, 1);
  const double blinn[] = {0.7, 30.0}, ggx[] = {0.3, 0.35, 7.0}, phong[] = {0.7, 30.0};
  double phong_worst = 0;
  for (int i = 0; i < 200; ++i) {
    const glm::dvec3 l = RandomUpperDirection(rng), v = RandomUpperDirection(rng);
    const double b = Brdf<BlinnPhong>(blinn, n, l, v), b_swapped = Brdf<BlinnPhong>(blinn, n, v, l);
    EXPECT_NEAR(b, b_swapped, 1e-12 * std::max(1.0, b));
    const double c = Brdf<Ggx>(ggx, n, l, v), c_swapped = Brdf<Ggx>(ggx, n, v, l);
    EXPECT_NEAR(c, c_swapped, 1e-12 * std::max(1.0, c));
    const double p = Brdf<Phong>(phong, n, l, v), p_swapped = Brdf<Phong>(phong, n, v, l);
    phong_worst = std::max(phong_worst, std::abs(p - p_swapped) / std::max(1e-12, std::max(p, p_swapped)));
  }
  // The thesis's lobe has no cosine: its BRDF is h^ke / (n.l), not symmetric.
  EXPECT_GT(phong_worst, 0.1);
}

// The integral over the hemisphere of directions l of f(geometry of l and
// v), v at `view_angle` from n (midpoint rule in theta, phi).
template <typename F>
double OverHemisphere(double view_angle, int theta_steps, F f) {
  const glm::dvec3 n(0, 0, 1), v(std::sin(view_angle), 0, std::cos(view_angle));
  const int phi_steps = 2 * theta_steps;
  double sum = 0;
  for (int i = 0; i < theta_steps; ++i) {
    const double theta = (i + 0.5) * (0.5 * kPi / theta_steps);
    for (int j = 0; j < phi_steps; ++j) {
      const double phi = (j + 0.5) * (2.0 * kPi / phi_steps);
      const glm::dvec3 l(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      sum += f(GeometryOf(n, l, v)) * std::sin(theta);
    }
  }
  return sum * (0.5 * kPi / theta_steps) * (2.0 * kPi / phi_steps);
}

// Directional albedo: the radiance reflected towards v under unit radiance
// from every direction, = integral over l of L(l, v) (L includes n.l).
template <typename M>
double Albedo(const double* p, double view_angle) {
  return OverHemisphere(view_angle, 600, [&](const Geometry& g) { return M::Specular(p, g, nullptr); });
}

// The diffuse part's directional albedo for kd = 1 / pi (a white Lambertian
// surface): integral over l of W(l, v) n.l / pi.
template <typename M>
double DiffuseAlbedo(const double* p, double view_angle) {
  return OverHemisphere(view_angle, 300,
                        [&](const Geometry& g) { return M::DiffuseWeight(p, g, nullptr) * g.n_dot_l / kPi; });
}

// GGX's lobe with F = 1 (n.l D V): its Specular over F = F0 (1 + (phi - 1)
// (1 - v.h)^5).
struct GgxUnitFresnel {
  static double Specular(const double* p, const Geometry& g, double*) {
    const double m = 1.0 - std::clamp(g.v_dot_h, 0.0, 1.0);
    const double f = p[0] * (1.0 + (p[2] - 1.0) * m * m * m * m * m);
    return f > 0.0 ? Ggx::Specular(p, g, nullptr) / f : 0.0;
  }
};

TEST(BrdfEnergyTest, NormalisedModelsReflectAtMostWhatArrives) {
  const double deg = kPi / 180.0;
  constexpr double kF0 = 1.0 / Ggx::kDielectricRatio;  // F90 = 1
  const double blinn[] = {1.0, 40.0}, ggx_rough[] = {kF0, 0.5, Ggx::kDielectricRatio},
               ggx_smooth[] = {kF0, 0.3, Ggx::kDielectricRatio};
  for (double view : {0.0, 30.0, 60.0, 80.0}) {
    const double b = Albedo<BlinnPhong>(blinn, view * deg);
    // GGX's lobe with F = 1 (the most it can reflect), and at F0 = kF0 (F90 =
    // 1, a dielectric of index 1.5) specular and diffuse weight apart (glTF's
    // sum of the two, kd = 1 / pi, exceeds 1 at grazing views: 1.22 at 80
    // degrees, roughness 0.3; the model's, not this code's).
    const double r = Albedo<GgxUnitFresnel>(ggx_rough, view * deg);
    const double s = Albedo<GgxUnitFresnel>(ggx_smooth, view * deg);
    const double sf = Albedo<Ggx>(ggx_smooth, view * deg), d = DiffuseAlbedo<Ggx>(ggx_smooth, view * deg);
    std::printf("view %2.0f deg: albedo Blinn-Phong (ks 1, ke 40) %.6f, GGX (F 1) roughness 0.5 %.6f, 0.3 %.6f; "
                "F0 0.04: specular %.6f, diffuse (kd 1/pi) %.6f\n",
                view, b, r, s, sf, d);
    EXPECT_LE(b, 1.0 + kQuadratureError) << view;
    EXPECT_LE(r, 1.0 + kQuadratureError) << view;
    EXPECT_LE(s, 1.0 + kQuadratureError) << view;
    EXPECT_LE(sf, s) << view;
    EXPECT_LE(d, 1.0 - kF0 + kQuadratureError) << view;
  }
  // Not far below either (a factor lost in D or V would show): single
  // scattering loses a few percent at these roughnesses.
  EXPECT_GT(Albedo<GgxUnitFresnel>(ggx_smooth, 0.0), 0.9);
  EXPECT_GT(Albedo<BlinnPhong>(blinn, 0.0), 0.9);
  // The lobe's scale is F0's: twice F0, twice the specular albedo (the model
  // is linear in it, ggx.h), the diffuse weight unchanged.
  const double ggx_double[] = {2.0 * kF0, 0.3, Ggx::kDielectricRatio};
  EXPECT_NEAR(Albedo<Ggx>(ggx_double, 30.0 * deg), 2.0 * Albedo<Ggx>(ggx_smooth, 30.0 * deg), 1e-12);
  EXPECT_DOUBLE_EQ(DiffuseAlbedo<Ggx>(ggx_double, 30.0 * deg), DiffuseAlbedo<Ggx>(ggx_smooth, 30.0 * deg));
  // The thesis's lobe is not normalised: ks 1, ke 40 reflects far less than
  // a white surface would.
  const double phong[] = {1.0, 40.0};
  EXPECT_LT(Albedo<Phong>(phong, 0.0), 0.5);
}

TEST(BrdfModelTest, Names) {
  for (Model m : {Model::kPhong, Model::kBlinnPhong, Model::kGgx}) {
    auto parsed = ParseModel(ModelName(m));
    ASSERT_TRUE(parsed.ok());
    EXPECT_EQ(*parsed, m);
  }
  auto bad = ParseModel("cook");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("phong, blinn-phong, ggx"), absl::string_view::npos);
  EXPECT_EQ(std::string(ParameterNames(Model::kGgx)[1]), "roughness");
  EXPECT_EQ(std::string(ParameterNames(Model::kGgx)[2]), "f90_ratio");
  EXPECT_EQ(std::string(ParameterNames(Model::kPhong)[2]), "");
  EXPECT_EQ(NumParameters(Model::kGgx), 3);
  EXPECT_EQ(NumParameters(Model::kBlinnPhong), 2);
}

// The glTF export's GGX of any model (ggx_equivalent.h): GGX itself
// unchanged; Phong and Blinn-Phong at the same head-on peak, with the width
// rule of synth --brdf ggx (roughness^4 = 2 / (ke_half + 2)).
TEST(GgxEquivalentTest, SamePeakHeadOnAndTheWidthRule) {
  const ParameterVector ggx = {0.03, 0.4, 6.0};
  EXPECT_EQ(GgxEquivalent(Model::kGgx, ggx), ggx);
  const glm::dvec3 n(0, 0, 1);
  const Geometry head_on = GeometryOf(n, n, n);
  for (Model model : {Model::kPhong, Model::kBlinnPhong}) {
    const ParameterVector p = {0.2, 30.0, 0.0};
    const ParameterVector g = GgxEquivalent(model, p);
    const double ke_half = model == Model::kPhong ? 4.0 * p[1] : p[1];
    EXPECT_NEAR(g[1], std::pow(2.0 / (ke_half + 2.0), 0.25), 1e-12) << ModelName(model);
    const double peak = model == Model::kPhong ? Phong::Specular(p.data(), head_on, nullptr)
                                               : BlinnPhong::Specular(p.data(), head_on, nullptr);
    EXPECT_NEAR(Ggx::Specular(g.data(), head_on, nullptr), peak, 1e-12 * peak) << ModelName(model);
  }
  // And back: PhongEquivalent keeps the peak and the width rule.
  for (Model model : {Model::kBlinnPhong, Model::kGgx}) {
    const ParameterVector p = model == Model::kGgx ? ParameterVector{0.04, 0.3, Ggx::kDielectricRatio}
                                                         : ParameterVector{0.2, 120.0, 0.0};
    const ParameterVector there = GgxEquivalent(model, p);
    const ParameterVector back = GgxEquivalent(Model::kPhong, PhongEquivalent(model, p));
    EXPECT_NEAR(back[0], there[0], 1e-9 * there[0]) << ModelName(model);
    EXPECT_NEAR(back[1], there[1], 1e-9) << ModelName(model);
  }
  // Widths beyond GGX's bounds clamp to them.
  EXPECT_EQ(GgxEquivalent(Model::kBlinnPhong, {0.1, 1e9, 0.0})[1], Ggx::Parameters()[1].lower);
  EXPECT_EQ(GgxEquivalent(Model::kBlinnPhong, {0.1, 0.0, 0.0})[1], Ggx::Parameters()[1].upper);
}

}  // namespace
}  // namespace mvbrdf::brdf
