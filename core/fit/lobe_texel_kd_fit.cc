#include "core/fit/lobe_texel_kd_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/brdf/ggx.h"
#include "core/fit/texel_kd_projection.h"

namespace mvbrdf::fit {
namespace {

bool IsFinite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// The used Samples: per Sample its dense texel, frame parity, reflectance and
// terms (light, g, a, geometry) of the selected lights.
struct Prepared {
  std::vector<uint32_t> texel;
  std::vector<uint8_t> fold;
  std::vector<std::array<double, 3>> r;
  std::vector<uint64_t> begin = {0};
  std::vector<uint16_t> light;
  std::vector<double> g, a;
  std::vector<brdf::Geometry> geometry;
  size_t num_texels = 0;
};

Prepared Prepare(const samples::SampleSet& set, const samples::LightSelection& selection) {
  Prepared p;
  std::vector<uint32_t> elements;
  for (size_t i = 0; i < set.size(); ++i) {
    if (!IsFinite(set.reflectance[i])) continue;
    bool finite = true;
    for (size_t j = set.TermsBegin(i); finite && j < set.TermsEnd(i); ++j) {
      finite = std::isfinite(set.g[j]) && std::isfinite(set.h[j]) && std::isfinite(set.TermFalloff(j)) &&
               (!set.half_vector || (std::isfinite(set.n_dot_h[j]) && std::isfinite(set.v_dot_h[j])));
    }
    if (!finite) continue;
    for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) {
      if (!selection.Selects(set.frame[i], set.light[j]) || !(set.g[j] > 0.0f)) continue;
      p.light.push_back(set.light[j]);
      p.g.push_back(set.g[j]);
      p.a.push_back(set.TermFalloff(j));
      p.geometry.push_back(TermGeometry(set, i, j));
    }
    elements.push_back(set.element[i]);
    p.fold.push_back(static_cast<uint8_t>(set.frame[i] & 1u));
    p.r.push_back({set.reflectance[i].x, set.reflectance[i].y, set.reflectance[i].z});
    p.begin.push_back(p.light.size());
  }
  p.texel = internal::DenseTexels(elements, &p.num_texels);
  return p;
}

// The regressors of channel c at the searched variable v (texel_kd_projection.h):
// G with the model's diffuse weight, S1 = S(1) - S(0) and S0 = S(0) at the
// parameters `at(v)` with p0 0 and 1 (the search is over the shape, or over
// GGX's f90_ratio with the shape held).
internal::TexelKdProblem::Regressors ModelRegressors(BrdfModel model, const Prepared& p,
                                                     const std::vector<glm::vec3>& intensity, int c,
                                                     std::function<brdf::ParameterVector(double)> at) {
  return [model, &p, &intensity, c, at](double v, std::vector<double>* g, std::vector<double>* s1,
                                        std::vector<double>* s0) {
    const size_t n = p.r.size();
    g->assign(n, 0.0);
    s1->assign(n, 0.0);
    s0->assign(n, 0.0);
    brdf::ParameterVector zero = at(v), one = zero;
    zero[0] = 0.0;
    one[0] = 1.0;
    for (size_t i = 0; i < n; ++i) {
      for (uint64_t j = p.begin[i]; j < p.begin[i + 1]; ++j) {
        const double light = intensity[p.light[j]][c];
        const brdf::Geometry& geometry = p.geometry[j];
        const double at_zero = ModelSpecular(model, zero, geometry);
        (*g)[i] += light * ModelDiffuseWeight(model, zero, geometry) * p.g[j];
        (*s0)[i] += light * p.a[j] * at_zero;
        (*s1)[i] += light * p.a[j] * (ModelSpecular(model, one, geometry) - at_zero);
      }
    }
  };
}

}  // namespace

absl::StatusOr<LobeTexelKdResult> FitModelLobeWithTexelKd(BrdfModel model, const samples::SampleSet& set,
                                                          const samples::LightSelection& lights,
                                                          const std::array<LobeChannel, 3>& initial,
                                                          const LobeTexelKdOptions& options) {
  if (!(options.ke_min > 0.0) || !(options.ke_max > options.ke_min) || !(options.ks_max > 0.0) ||
      options.grid_points < 3 || options.golden_iterations < 0 || !(options.min_information >= 0.0)) {
    return absl::InvalidArgumentError(
        "LobeTexelKdOptions: need 0 < ke_min < ke_max, ks_max > 0, grid_points >= 3, golden_iterations >= 0, "
        "min_information >= 0");
  }
  if (brdf::NeedsHalfVector(model) && !set.half_vector) {
    return absl::FailedPreconditionError(
        absl::StrCat("the ", brdf::ModelName(model), " model reads n.h and v.h: its Samples need the half-vector "
                     "geometry (SampleSet::half_vector)"));
  }
  const auto start = std::chrono::steady_clock::now();
  const Prepared p = Prepare(set, lights);
  LobeTexelKdResult result;
  result.params = initial;
  result.samples_used = p.r.size();
  result.texels = p.num_texels;
  const bool ggx = model == BrdfModel::kGgx;
  // The shape's search interval: ln ke, or the roughness itself.
  const double lo = ggx ? brdf::Ggx::Parameters()[1].lower : std::log(options.ke_min);
  const double hi = ggx ? brdf::Ggx::Parameters()[1].upper
                        : std::log(model == BrdfModel::kBlinnPhong ? 4.0 * options.ke_max : options.ke_max);
  const auto shape_of = [ggx](double u) { return ggx ? u : std::exp(u); };
  for (int c = 0; c < 3; ++c) {
    if (p.r.empty()) break;
    double rr = 0.0, gg = 0.0;
    for (size_t i = 0; i < p.r.size(); ++i) {
      rr += p.r[i][c] * p.r[i][c];
      double g = 0.0;
      for (uint64_t j = p.begin[i]; j < p.begin[i + 1]; ++j) g += set.light_intensity[p.light[j]][c] * p.g[j];
      gg += g * g;
    }
    if (!(gg > 0.0)) continue;
    const double albedo_scale = rr > 0.0 ? std::sqrt(rr / gg) : 1.0;
    const double p0_max = options.ks_max * albedo_scale;
    std::vector<double> r(p.r.size());
    for (size_t i = 0; i < p.r.size(); ++i) r[i] = p.r[i][c];
    // Problems over the shape at a fixed third parameter, and over the third
    // (GGX's f90_ratio, in ln) at a fixed shape.
    const auto over_shape = [&](double p2) {
      return internal::TexelKdProblem(
          p.texel, p.fold, p.num_texels, r, p0_max,
          ModelRegressors(model, p, set.light_intensity, c,
                          [p2](double shape) { return brdf::ParameterVector{0.0, shape, p2}; }));
    };
    const auto over_p2 = [&](double shape) {
      return internal::TexelKdProblem(
          p.texel, p.fold, p.num_texels, r, p0_max,
          ModelRegressors(model, p, set.light_intensity, c,
                          [shape](double p2) { return brdf::ParameterVector{0.0, shape, p2}; }));
    };
    const double shape0 = ggx ? std::clamp(initial[c].p[1], lo, hi) : std::clamp(initial[c].p[1], std::exp(lo), std::exp(hi));
    const double p00 = std::clamp(initial[c].p[0], 0.0, p0_max);
    internal::TexelKdProblem problem = over_shape(initial[c].p[2]);
    const internal::TexelKdProblem::Evaluation at_initial = problem.Evaluate(shape0, p00);
    const internal::TexelKdProblem::Search search =
        problem.SearchShape(lo, hi, options.grid_points, options.golden_iterations, shape_of);
    double best_shape = shape_of(search.u), best_p2 = initial[c].p[2];
    internal::TexelKdProblem::Evaluation best_e = search.at;
    if (brdf::NumParameters(model) > 2) {
      // The third parameter at the best shape (the one-kd fit's was pulled by
      // the texture, as its lobe was), then the shape again at it.
      const brdf::Parameter& bounds = brdf::Ggx::Parameters()[2];
      const double mean_rr = rr / static_cast<double>(p.r.size());
      const auto prior = [&](double u) {
        if (!(options.ratio_prior_sigma > 0.0)) return 0.0;
        const double z = (u - std::log(brdf::Ggx::kDielectricRatio)) / options.ratio_prior_sigma;
        return 0.5 * mean_rr * z * z;
      };
      const internal::TexelKdProblem::Search ratio =
          over_p2(best_shape).SearchShape(std::log(bounds.lower), std::log(bounds.upper), options.grid_points,
                                          options.golden_iterations, [](double u) { return std::exp(u); }, prior);
      if (ratio.at.cost + prior(ratio.u) < best_e.cost + prior(std::log(best_p2))) {
        best_p2 = std::exp(ratio.u);
        best_e = ratio.at;
        const internal::TexelKdProblem::Search again =
            over_shape(best_p2).SearchShape(lo, hi, options.grid_points, options.golden_iterations, shape_of);
        if (again.at.cost < best_e.cost) {
          best_shape = shape_of(again.u);
          best_e = again.at;
        }
      }
    }
    if (best_e.information < options.min_information || !(best_e.cost <= at_initial.cost) ||
        !std::isfinite(best_e.p0)) {
      continue;
    }
    size_t count = 0;
    result.held_out_error_initial[c] = problem.HeldOutError(p00, shape0, &count);
    result.held_out_error[c] = over_shape(best_p2).HeldOutError(best_e.p0, best_shape, &count);
    if (count > 0 && !(result.held_out_error[c] <= result.held_out_error_initial[c])) continue;
    result.params[c] = {best_e.kd, {best_e.p0, best_shape, best_p2}};
    result.refined[c] = true;
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace mvbrdf::fit
