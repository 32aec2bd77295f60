#include "core/fit/texel_kd_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "core/fit/phong_terms.h"
#include "core/fit/texel_kd_projection.h"

namespace mvbrdf::fit {
namespace {

using samples::LightSelection;
using samples::SampleSet;

bool IsFinite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// The Samples of one fit, per channel-independent form.
struct Prepared {
  std::vector<uint32_t> texel;           // dense texel index per Sample
  std::vector<uint8_t> fold;             // frame parity per Sample (held-out check)
  std::vector<std::array<double, 3>> r;  // reflectance
  std::vector<std::array<double, 3>> g;  // G per channel
  std::vector<uint64_t> begin = {0};     // the Sample's highlight terms
  std::vector<double> log_h;             // ln h of terms with h > 0
  std::vector<std::array<double, 3>> w;  // I_kc a_k of those terms
  size_t num_texels = 0;
};

Prepared Prepare(const SampleSet& set, const LightSelection& selection) {
  Prepared p;
  std::vector<uint32_t> elements;
  for (size_t i = 0; i < set.size(); ++i) {
    if (!IsFinite(set.reflectance[i])) continue;
    std::array<double, 3> g = {0.0, 0.0, 0.0};
    bool finite = true;
    const size_t before = p.log_h.size();
    for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) {
      const int k = set.light[j];
      if (!selection.Selects(set.frame[i], static_cast<size_t>(k))) continue;
      if (!std::isfinite(set.g[j]) || !std::isfinite(set.h[j]) || !std::isfinite(set.TermFalloff(j))) {
        finite = false;
        break;
      }
      const double gc = internal::ClampedCosine(set.g[j]);
      if (gc <= 0.0) continue;
      for (int c = 0; c < 3; ++c) g[c] += set.light_intensity[k][c] * gc;
      const double h = internal::ClampedHighlight(gc, set.h[j]);
      if (h <= 0.0) continue;
      p.log_h.push_back(std::log(h));
      const double a = set.TermFalloff(j);
      p.w.push_back({set.light_intensity[k][0] * a, set.light_intensity[k][1] * a, set.light_intensity[k][2] * a});
    }
    if (!finite) {
      p.log_h.resize(before);
      p.w.resize(before);
      continue;
    }
    elements.push_back(set.element[i]);
    p.fold.push_back(static_cast<uint8_t>(set.frame[i] & 1u));
    p.r.push_back({set.reflectance[i].x, set.reflectance[i].y, set.reflectance[i].z});
    p.g.push_back(g);
    p.begin.push_back(p.log_h.size());
  }
  p.texel = internal::DenseTexels(elements, &p.num_texels);
  return p;
}

// The regressors of channel c at exponent ke (texel_kd_projection.h): G, no
// fixed part, and S_i(ke) = sum_k I_kc a_k h_ik^ke.
internal::TexelKdProblem::Regressors PhongRegressors(const Prepared& p, int c) {
  return [&p, c](double ke, std::vector<double>* g, std::vector<double>* s1, std::vector<double>* s0) {
    const size_t n = p.r.size();
    g->resize(n);
    s1->assign(n, 0.0);
    s0->assign(n, 0.0);
    for (size_t i = 0; i < n; ++i) {
      (*g)[i] = p.g[i][c];
      double s = 0.0;
      for (uint64_t j = p.begin[i]; j < p.begin[i + 1]; ++j) s += p.w[j][c] * std::exp(ke * p.log_h[j]);
      (*s1)[i] = s;
    }
  };
}

}  // namespace

absl::StatusOr<TexelKdFitResult> FitLobeWithTexelKd(const SampleSet& set, const LightSelection& mask,
                                                    const PhongRgb& initial, const TexelKdFitOptions& options) {
  if (!(options.ke_min > 0.0) || !(options.ke_max > options.ke_min) || !(options.ks_max > 0.0) ||
      options.grid_points < 3 || options.golden_iterations < 0 || !(options.min_information >= 0.0)) {
    return absl::InvalidArgumentError(
        "TexelKdFitOptions: need 0 < ke_min < ke_max, ks_max > 0, grid_points >= 3, golden_iterations >= 0, "
        "min_information >= 0");
  }
  const auto start = std::chrono::steady_clock::now();
  const Prepared p = Prepare(set, mask);
  TexelKdFitResult result;
  result.samples_used = p.r.size();
  result.texels = p.num_texels;
  result.params = initial;
  const double lo = std::log(options.ke_min), hi = std::log(options.ke_max);
  for (int c = 0; c < 3; ++c) {
    TexelKdChannel& out = result.channels[c];
    out.ks = initial[c].ks;
    out.ke = initial[c].ke;
    out.kd = initial[c].kd;
    if (p.r.empty()) continue;
    // The data's albedo scale (as FitPhong's bounds).
    double rr = 0.0, gg = 0.0;
    for (size_t i = 0; i < p.r.size(); ++i) {
      rr += p.r[i][c] * p.r[i][c];
      gg += p.g[i][c] * p.g[i][c];
    }
    if (!(gg > 0.0)) continue;
    const double albedo_scale = rr > 0.0 ? std::sqrt(rr / gg) : 1.0;
    std::vector<double> r(p.r.size());
    for (size_t i = 0; i < p.r.size(); ++i) r[i] = p.r[i][c];
    internal::TexelKdProblem problem(p.texel, p.fold, p.num_texels, std::move(r), options.ks_max * albedo_scale,
                                     PhongRegressors(p, c));
    const double ke0 = std::clamp(initial[c].ke, options.ke_min, options.ke_max);
    const internal::TexelKdProblem::Evaluation at_initial = problem.Evaluate(ke0, std::max(0.0, initial[c].ks));
    out.initial_cost = at_initial.cost;
    out.cost = at_initial.cost;
    const internal::TexelKdProblem::Search search =
        problem.SearchShape(lo, hi, options.grid_points, options.golden_iterations, [](double u) { return std::exp(u); });
    const double best_u = search.u;
    const internal::TexelKdProblem::Evaluation& best_e = search.at;
    if (best_e.information < options.min_information || !(best_e.cost <= at_initial.cost) ||
        !std::isfinite(best_e.p0)) {
      continue;  // the data does not inform the lobe beyond the texels' own kd
    }
    // Kept only when it predicts the other frames at least as well as the
    // initial lobe (both with per-texel kd from the fitted frames).
    size_t held_out_count = 0;
    out.held_out_error_initial = problem.HeldOutError(std::max(0.0, initial[c].ks), ke0, &held_out_count);
    out.held_out_error = problem.HeldOutError(best_e.p0, std::exp(best_u), &held_out_count);
    if (held_out_count > 0 && !(out.held_out_error <= out.held_out_error_initial)) continue;
    out.ks = best_e.p0;
    out.ke = std::exp(best_u);
    out.kd = best_e.kd;
    out.cost = best_e.cost;
    out.refined = true;
    result.params[c] = {out.kd, out.ks, out.ke};
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace mvbrdf::fit
