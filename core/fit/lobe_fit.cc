#include "core/fit/lobe_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "ceres/ceres.h"
#include "core/brdf/blinn_phong.h"
#include "core/brdf/geometry.h"
#include "core/brdf/ggx.h"
#include "core/brdf/phong.h"

namespace mvbrdf::fit {
namespace {

// One model's functions (core/brdf): the specular radiance and the diffuse
// weight with their Jacobians in the model's own parameters.
struct ModelFunctions {
  double (*specular)(const double*, const brdf::Geometry&, double*);
  double (*diffuse_weight)(const double*, const brdf::Geometry&, double*);
};

ModelFunctions FunctionsOf(BrdfModel model) {
  switch (model) {
    case BrdfModel::kPhong:
      return {&brdf::Phong::Specular, &brdf::Phong::DiffuseWeight};
    case BrdfModel::kBlinnPhong:
      return {&brdf::BlinnPhong::Specular, &brdf::BlinnPhong::DiffuseWeight};
    case BrdfModel::kGgx:
      return {&brdf::Ggx::Specular, &brdf::Ggx::DiffuseWeight};
  }
  return {&brdf::Phong::Specular, &brdf::Phong::DiffuseWeight};
}

// The terms of the used samples, shared by the channels: per term the light,
// g, a and the geometry.
struct Terms {
  std::vector<uint64_t> begin = {0};
  std::vector<uint16_t> light;
  std::vector<double> g, a;
  std::vector<brdf::Geometry> geometry;
  std::vector<size_t> sample;  // the set's sample index per used sample
  size_t size() const { return sample.size(); }
};

}  // namespace

brdf::Geometry TermGeometry(const samples::SampleSet& set, size_t i, size_t j) {
  brdf::Geometry geometry;
  const double a = set.TermFalloff(j);
  geometry.n_dot_l = a > 0.0 ? std::min(1.0, static_cast<double>(set.g[j]) / a) : 0.0;
  geometry.r_dot_v = set.h[j];
  if (set.half_vector) {
    geometry.n_dot_v = set.n_dot_v[i];
    geometry.n_dot_h = set.n_dot_h[j];
    geometry.v_dot_h = set.v_dot_h[j];
  }
  return geometry;
}

double ModelSpecular(BrdfModel model, const brdf::ParameterVector& p, const brdf::Geometry& geometry) {
  return FunctionsOf(model).specular(p.data(), geometry, nullptr);
}

double ModelDiffuseWeight(BrdfModel model, const brdf::ParameterVector& p, const brdf::Geometry& geometry) {
  return FunctionsOf(model).diffuse_weight(p.data(), geometry, nullptr);
}

namespace {

// The solver's parameters x = (kd / A, s0, s1, s2): s0 = ks / A (Phong,
// Blinn-Phong) or F0 / A (GGX; every model's first parameter is its lobe's
// scale, in the data's units); s1 = ln ke or the roughness; s2 = GGX's
// f90_ratio (held constant for the models with two parameters).
constexpr int kSolverParameters = 1 + brdf::kMaxParameters;
using SolverVector = std::array<double, kSolverParameters>;

struct Scaling {
  BrdfModel model;
  double albedo = 1.0;  // A
  LobeChannel ToChannel(const double* x) const {
    LobeChannel c;
    c.kd = x[0] * albedo;
    c.p[0] = x[1] * albedo;
    c.p[1] = model == BrdfModel::kGgx ? x[2] : std::exp(x[2]);
    c.p[2] = x[3];
    return c;
  }
  // d(model parameter) / d(solver parameter) for p[0], p[1], p[2].
  brdf::ParameterVector Chain(const double* x) const {
    return {albedo, model == BrdfModel::kGgx ? 1.0 : std::exp(x[2]), 1.0};
  }
};

// f_i and df_i/dx for one channel.
double ModelValue(const ModelFunctions& m, const Terms& t, const std::vector<double>& intensity, size_t s,
                  const Scaling& scaling, const double* x, double* jacobian) {
  const LobeChannel c = scaling.ToChannel(x);
  const brdf::ParameterVector chain = scaling.Chain(x);
  constexpr int kP = brdf::kMaxParameters;
  double f = 0.0, d[kSolverParameters] = {};
  double js[kP] = {}, jw[kP] = {};
  for (uint64_t j = t.begin[s]; j < t.begin[s + 1]; ++j) {
    const double intensity_k = intensity[t.light[j]];
    const double w = m.diffuse_weight(c.p.data(), t.geometry[j], jacobian != nullptr ? jw : nullptr);
    const double spec = m.specular(c.p.data(), t.geometry[j], jacobian != nullptr ? js : nullptr);
    f += intensity_k * (c.kd * w * t.g[j] + t.a[j] * spec);
    if (jacobian != nullptr) {
      d[0] += intensity_k * scaling.albedo * w * t.g[j];
      for (int q = 0; q < kP; ++q) d[1 + q] += intensity_k * (c.kd * jw[q] * t.g[j] + t.a[j] * js[q]) * chain[q];
    }
  }
  if (jacobian != nullptr) std::copy(d, d + kSolverParameters, jacobian);
  return f;
}

class LobeResidual : public ceres::SizedCostFunction<1, kSolverParameters> {
 public:
  LobeResidual(const ModelFunctions* m, const Terms* t, const std::vector<double>* intensity, size_t s, double r,
               const Scaling* scaling, double inverse_scale)
      : m_(m), t_(t), intensity_(intensity), s_(s), r_(r), scaling_(scaling), inverse_scale_(inverse_scale) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    double d[kSolverParameters];
    const bool want = jacobians != nullptr && jacobians[0] != nullptr;
    const double f = ModelValue(*m_, *t_, *intensity_, s_, *scaling_, parameters[0], want ? d : nullptr);
    residuals[0] = (r_ - f) * inverse_scale_;
    if (want) {
      for (int q = 0; q < kSolverParameters; ++q) jacobians[0][q] = -d[q] * inverse_scale_;
    }
    return std::isfinite(residuals[0]);
  }

 private:
  const ModelFunctions* m_;
  const Terms* t_;
  const std::vector<double>* intensity_;
  size_t s_;
  double r_;
  const Scaling* scaling_;
  double inverse_scale_;
};

// GGX's prior on its ratio x[3]: (ln x[3] - ln 25) / sigma.
class RatioPrior : public ceres::SizedCostFunction<1, kSolverParameters> {
 public:
  explicit RatioPrior(double sigma) : sigma_(sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double ratio = parameters[0][3];
    if (!(ratio > 0.0)) return false;
    residuals[0] = (std::log(ratio) - std::log(brdf::Ggx::kDielectricRatio)) / sigma_;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      std::fill(jacobians[0], jacobians[0] + kSolverParameters, 0.0);
      jacobians[0][3] = 1.0 / (ratio * sigma_);
    }
    return true;
  }

 private:
  double sigma_;
};

// 0.5 sum (r - f)^2 in the data's units.
double Cost(const ModelFunctions& m, const Terms& t, const std::vector<double>& intensity,
            const std::vector<double>& r, const Scaling& scaling, const double* x) {
  double cost = 0.0;
  for (size_t s = 0; s < t.size(); ++s) {
    const double e = r[s] - ModelValue(m, t, intensity, s, scaling, x, nullptr);
    cost += 0.5 * e * e;
  }
  return cost;
}

// The best x on a grid of shapes, kd and the lobe's scale by least squares;
// s2 as given (GGX's dielectric ratio).
SolverVector InitialGuess(BrdfModel model, const ModelFunctions& m, const Terms& t,
                          const std::vector<double>& intensity, const std::vector<double>& r,
                          const Scaling& scaling, const double* lower, const double* upper, double s2) {
  std::vector<double> shapes;
  if (model == BrdfModel::kGgx) {
    shapes = {0.02, 0.035, 0.05, 0.075, 0.1, 0.15, 0.2, 0.3, 0.4, 0.55, 0.7, 0.85, 1.0};
  } else {
    const double ke_top = model == BrdfModel::kBlinnPhong ? 20000.0 : 5000.0;
    for (double ke = 2.0; ke <= ke_top; ke *= 1.6) shapes.push_back(std::log(ke));
  }
  SolverVector best = {0.0, 0.0, shapes.front(), s2};
  double best_cost = std::numeric_limits<double>::infinity();
  for (double shape : shapes) {
    shape = std::clamp(shape, lower[2], upper[2]);
    // Diffuse and specular regressors at kd = 1 and a lobe scale of 1 (every
    // model's diffuse weight is independent of that scale).
    double x_unit[kSolverParameters] = {0.0, 1.0, shape, s2};
    double sdd = 0, sds = 0, sss = 0, sdr = 0, ssr = 0;
    for (size_t s = 0; s < t.size(); ++s) {
      x_unit[0] = 0.0;
      const double spec = ModelValue(m, t, intensity, s, scaling, x_unit, nullptr);
      x_unit[0] = 1.0;
      const double diffuse = ModelValue(m, t, intensity, s, scaling, x_unit, nullptr) - spec;
      sdd += diffuse * diffuse;
      sds += diffuse * spec;
      sss += spec * spec;
      sdr += diffuse * r[s];
      ssr += spec * r[s];
    }
    double kd = 0.0, ks = 1.0;
    const double det = sdd * sss - sds * sds;
    if (det > 1e-300) {
      kd = (sdr * sss - ssr * sds) / det;
      ks = (ssr * sdd - sdr * sds) / det;
    }
    if (!(ks >= 0.0)) {  // the lobe only where it helps
      ks = 0.0;
      kd = sdd > 0.0 ? sdr / sdd : 0.0;
    }
    if (!(kd >= 0.0)) {
      kd = 0.0;
      ks = sss > 0.0 ? std::max(0.0, ssr / sss) : 0.0;
    }
    const SolverVector x = {std::clamp(kd, lower[0], upper[0]), std::clamp(ks, lower[1], upper[1]), shape, s2};
    const double cost = Cost(m, t, intensity, r, scaling, x.data());
    if (cost < best_cost) {
      best_cost = cost;
      best = x;
    }
  }
  return best;
}

}  // namespace

absl::Status LobeFitOptions::Check() const {
  // The same ranges as the Phong fit's options, with the same messages.
  PhongFitOptions phong;
  phong.max_iterations = max_iterations;
  phong.function_tolerance = function_tolerance;
  phong.kd_max = kd_max;
  phong.ks_max = ks_max;
  phong.ke_min = ke_min;
  phong.ke_max = ke_max;
  phong.highlight_cosine = highlight_cosine;
  return phong.Check();
}

void LobeTerms(BrdfModel model, const std::array<LobeChannel, 3>& p, const samples::LightTerms& terms,
               const std::vector<glm::vec3>& intensity, const samples::LightMask& mask, glm::vec3* specular,
               glm::vec3* illumination) {
  const ModelFunctions m = FunctionsOf(model);
  glm::dvec3 s(0.0), g(0.0);
  for (size_t j = 0; j < terms.count; ++j) {
    const size_t k = terms.light[j];
    if (!mask.Test(k)) continue;
    brdf::Geometry geometry;
    const double a = terms.falloff != nullptr ? terms.falloff[j] : 1.0;
    geometry.n_dot_l = a > 0.0 ? std::min(1.0, static_cast<double>(terms.g[j]) / a) : 0.0;
    geometry.r_dot_v = terms.h[j];
    geometry.n_dot_v = terms.n_dot_v;
    if (terms.n_dot_h != nullptr) geometry.n_dot_h = terms.n_dot_h[j];
    if (terms.v_dot_h != nullptr) geometry.v_dot_h = terms.v_dot_h[j];
    for (int c = 0; c < 3; ++c) {
      s[c] += intensity[k][c] * a * m.specular(p[c].p.data(), geometry, nullptr);
      g[c] += intensity[k][c] * m.diffuse_weight(p[c].p.data(), geometry, nullptr) * terms.g[j];
    }
  }
  *specular = glm::vec3(s);
  *illumination = glm::vec3(g);
}

double EvaluateLobe(BrdfModel model, const samples::SampleSet& set, size_t i, const samples::LightSelection& lights,
                    const LobeChannel& p, int c) {
  const ModelFunctions m = FunctionsOf(model);
  const bool own = lights.Own(set.frame[i]);
  double f = 0.0;
  for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) {
    if (!own && !lights.config.Test(set.light[j])) continue;
    const brdf::Geometry geometry = TermGeometry(set, i, j);
    const double w = m.diffuse_weight(p.p.data(), geometry, nullptr);
    const double spec = m.specular(p.p.data(), geometry, nullptr);
    f += set.light_intensity[set.light[j]][c] * (p.kd * w * set.g[j] + set.TermFalloff(j) * spec);
  }
  return f;
}

absl::StatusOr<LobeFitResult> FitLobe(BrdfModel model, const samples::SampleSet& set,
                                      const std::vector<uint32_t>& indices, const samples::LightSelection& lights,
                                      const LobeFitOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  if (absl::Status s = options.Check(); !s.ok()) return s;
  if (brdf::NeedsHalfVector(model) && !set.half_vector) {
    return absl::FailedPreconditionError(absl::StrCat("the ", brdf::ModelName(model),
                                                      " model reads n.h and v.h: its Samples must be gathered with "
                                                      "the half-vector geometry (SampleSet::half_vector)"));
  }
  const ModelFunctions m = FunctionsOf(model);
  LobeFitResult result;
  result.model = model;

  // The used samples and their terms (the lights of the selection).
  Terms t;
  uint32_t input_flags = kFitOk;
  const size_t n_all = indices.empty() ? set.size() : indices.size();
  for (size_t u = 0; u < n_all; ++u) {
    const size_t i = indices.empty() ? u : indices[u];
    if (i >= set.size()) return absl::InvalidArgumentError(absl::StrCat("sample index ", i, " out of range"));
    bool finite = std::isfinite(set.reflectance[i].x) && std::isfinite(set.reflectance[i].y) &&
                  std::isfinite(set.reflectance[i].z);
    for (size_t j = set.TermsBegin(i); finite && j < set.TermsEnd(i); ++j) {
      finite = std::isfinite(set.g[j]) && std::isfinite(set.h[j]) && std::isfinite(set.TermFalloff(j)) &&
               (!set.half_vector || (std::isfinite(set.n_dot_h[j]) && std::isfinite(set.v_dot_h[j])));
    }
    if (!finite) {
      input_flags |= kNonFiniteInput;
      continue;
    }
    const bool own = lights.Own(set.frame[i]);
    for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) {
      if (!own && !lights.config.Test(set.light[j])) continue;
      t.light.push_back(set.light[j]);
      t.g.push_back(set.g[j]);
      t.a.push_back(set.TermFalloff(j));
      t.geometry.push_back(TermGeometry(set, i, j));
    }
    t.begin.push_back(t.light.size());
    t.sample.push_back(i);
  }
  result.samples_used = t.size();
  if (t.size() == 0) {
    for (auto& c : result.channels) c.flags = kNoSamples | input_flags;
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  }
  // Highlight samples: a lobe cosine (R(l).v for Phong, n.h otherwise) above
  // the threshold in some term.
  int highlights = 0;
  for (size_t s = 0; s < t.size(); ++s) {
    for (uint64_t j = t.begin[s]; j < t.begin[s + 1]; ++j) {
      const double cosine = model == BrdfModel::kPhong ? t.geometry[j].r_dot_v : t.geometry[j].n_dot_h;
      if (cosine > options.highlight_cosine) {
        ++highlights;
        break;
      }
    }
  }

  double squared_error = 0.0;
  for (int c = 0; c < 3; ++c) {
    ChannelFitSummary& summary = result.channels[c];
    summary.flags = input_flags;
    std::vector<double> intensity(set.light_intensity.size());
    for (size_t k = 0; k < intensity.size(); ++k) intensity[k] = set.light_intensity[k][c];
    std::vector<double> r(t.size());
    double sum_rr = 0.0, sum_gg = 0.0;
    for (size_t s = 0; s < t.size(); ++s) {
      r[s] = set.reflectance[t.sample[s]][c];
      sum_rr += r[s] * r[s];
      double diffuse = 0.0;
      for (uint64_t j = t.begin[s]; j < t.begin[s + 1]; ++j) diffuse += intensity[t.light[j]] * t.g[j];
      sum_gg += diffuse * diffuse;
    }
    Scaling scaling{model};
    const double r_rms = std::sqrt(sum_rr / static_cast<double>(t.size()));
    scaling.albedo = sum_gg > 0.0 && r_rms > 0.0 ? r_rms / std::sqrt(sum_gg / static_cast<double>(t.size())) : 1.0;
    if (!std::isfinite(scaling.albedo) || !(scaling.albedo > 0.0)) scaling.albedo = 1.0;
    if (sum_gg <= 0.0) summary.flags |= kKdNotIdentifiable;
    if (highlights < options.min_highlight_samples) summary.flags |= kKsKeNotIdentifiable;

    double lower[kSolverParameters], upper[kSolverParameters];
    lower[0] = 0.0;
    upper[0] = options.kd_max;
    lower[1] = 0.0;
    upper[1] = options.ks_max;
    // GGX's ratio starts at a dielectric's; the others have none (held).
    double s2 = 0.0;
    lower[3] = upper[3] = 0.0;
    if (model == BrdfModel::kGgx) {
      const auto& p = brdf::Ggx::Parameters();
      lower[2] = p[1].lower;
      upper[2] = p[1].upper;
      lower[3] = p[2].lower;
      upper[3] = p[2].upper;
      s2 = brdf::Ggx::kDielectricRatio;
    } else {
      lower[2] = std::log(options.ke_min);
      // A half-vector exponent is ~4x the mirror one of the same lobe.
      upper[2] = std::log(model == BrdfModel::kBlinnPhong ? 4.0 * options.ke_max : options.ke_max);
    }
    SolverVector x = InitialGuess(model, m, t, intensity, r, scaling, lower, upper, s2);
    const double inverse_scale = r_rms > 0.0 ? 1.0 / r_rms : 1.0;
    summary.initial_cost = Cost(m, t, intensity, r, scaling, x.data());

    ceres::Problem::Options problem_options;
    problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    for (size_t s = 0; s < t.size(); ++s) {
      problem.AddResidualBlock(new LobeResidual(&m, &t, &intensity, s, r[s], &scaling, inverse_scale), nullptr,
                               x.data());
    }
    const int free_parameters = 1 + brdf::NumParameters(model);
    for (int q = 0; q < free_parameters; ++q) {
      problem.SetParameterLowerBound(x.data(), q, lower[q]);
      problem.SetParameterUpperBound(x.data(), q, upper[q]);
    }
    if (model == BrdfModel::kGgx && options.ratio_prior_sigma > 0.0) {
      problem.AddResidualBlock(new RatioPrior(options.ratio_prior_sigma), nullptr, x.data());
    }
    if (free_parameters < kSolverParameters) {
      std::vector<int> held;
      for (int q = free_parameters; q < kSolverParameters; ++q) held.push_back(q);
      problem.SetManifold(x.data(), new ceres::SubsetManifold(kSolverParameters, held));
    }
    ceres::Solver::Options solver_options;
    solver_options.minimizer_type = ceres::TRUST_REGION;
    solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    solver_options.linear_solver_type = ceres::DENSE_QR;
    solver_options.max_num_iterations = options.max_iterations;
    solver_options.function_tolerance = options.function_tolerance;
    solver_options.gradient_tolerance = 1e-14;
    solver_options.parameter_tolerance = 1e-12;
    solver_options.num_threads = 1;
    solver_options.logging_type = ceres::SILENT;
    ceres::Solver::Summary ceres_summary;
    ceres::Solve(solver_options, &problem, &ceres_summary);
    summary.iterations = static_cast<int>(ceres_summary.iterations.size());
    if (ceres_summary.termination_type == ceres::NO_CONVERGENCE) summary.flags |= kDidNotConverge;
    for (int q = 0; q < free_parameters; ++q) {
      if (!std::isfinite(x[q])) x[q] = lower[q];
      const double span = upper[q] - lower[q];
      // The ratio at 1 (a metal's flat curve) or 50 is a result, not a
      // parameter the data pushed out of range.
      if (q > 0 && q < 3 && (x[q] - lower[q] < 1e-6 * span || upper[q] - x[q] < 1e-6 * span)) {
        summary.flags |= kAtBound;
      }
    }
    summary.final_cost = Cost(m, t, intensity, r, scaling, x.data());
    squared_error += 2.0 * summary.final_cost;
    result.params[c] = scaling.ToChannel(x.data());
  }
  result.mse = squared_error / (3.0 * static_cast<double>(t.size()));
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace mvbrdf::fit
