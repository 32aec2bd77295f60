#include "core/fit/texel_kd_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include "absl/status/status.h"
#include "core/fit/phong_terms.h"

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
  std::vector<uint32_t> unique = elements;
  std::sort(unique.begin(), unique.end());
  unique.erase(std::unique(unique.begin(), unique.end()), unique.end());
  p.num_texels = unique.size();
  p.texel.resize(elements.size());
  for (size_t i = 0; i < elements.size(); ++i) {
    p.texel[i] = static_cast<uint32_t>(std::lower_bound(unique.begin(), unique.end(), elements[i]) - unique.begin());
  }
  return p;
}

// Per-texel sums at one ke for channel c, and the cost after eliminating kd_t.
class ChannelProblem {
 public:
  ChannelProblem(const Prepared& p, int c, double ks_max) : p_(p), c_(c), ks_max_(ks_max), sums_(p.num_texels) {}

  struct Evaluation {
    double ks = 0.0;
    double cost = 0.0;
    double information = 0.0;  // (sum S^2 - sum B^2 / A) / sum S^2
    double kd = 0.0;           // the cluster's kd at (ks, ke)
  };

  // At ke with ks solved (fixed_ks < 0) or given.
  Evaluation Evaluate(double ke, double fixed_ks = -1.0) {
    std::fill(sums_.begin(), sums_.end(), Sums{});
    for (size_t i = 0; i < p_.r.size(); ++i) {
      const double s = Specular(i, ke);
      const double g = p_.g[i][c_];
      const double r = p_.r[i][c_];
      Sums& t = sums_[p_.texel[i]];
      t.a += g * g;
      t.b += g * s;
      t.c += g * r;
      t.ss += s * s;
      t.sr += s * r;
      t.rr += r * r;
    }
    double num = 0.0, den = 0.0, ss = 0.0;
    for (const Sums& t : sums_) {
      ss += t.ss;
      num += t.sr;
      den += t.ss;
      if (t.a > 0.0) {
        num -= t.b * t.c / t.a;
        den -= t.b * t.b / t.a;
      }
    }
    Evaluation e;
    e.information = ss > 0.0 ? std::max(0.0, den) / ss : 0.0;
    if (fixed_ks >= 0.0) {
      e.ks = fixed_ks;
    } else {
      e.ks = den > 0.0 ? std::clamp(num / den, 0.0, ks_max_) : 0.0;
    }
    double cost = 0.0, ga = 0.0, gc = 0.0;
    for (const Sums& t : sums_) {
      const double kd = t.a > 0.0 ? std::max(0.0, (t.c - e.ks * t.b) / t.a) : 0.0;
      cost += t.rr - 2.0 * kd * t.c - 2.0 * e.ks * t.sr + kd * kd * t.a + 2.0 * kd * e.ks * t.b + e.ks * e.ks * t.ss;
      ga += t.a;
      gc += t.c - e.ks * t.b;
    }
    e.cost = 0.5 * std::max(0.0, cost);
    e.kd = ga > 0.0 ? std::max(0.0, gc / ga) : 0.0;
    return e;
  }

  // The lobe (ks, ke) on frames it was not fitted to: per texel, kd from the
  // Samples of one frame parity, the squared error on those of the other,
  // both ways; texels seen in one parity only do not count. Returns the mean
  // squared error and the number of Samples it is over in `count`.
  double HeldOutError(double ks, double ke, size_t* count) {
    std::vector<double> s(p_.r.size());
    for (size_t i = 0; i < p_.r.size(); ++i) s[i] = Specular(i, ke);
    double sse = 0.0;
    *count = 0;
    std::vector<double> a(p_.num_texels), c(p_.num_texels);
    for (uint8_t test = 0; test < 2; ++test) {
      std::fill(a.begin(), a.end(), 0.0);
      std::fill(c.begin(), c.end(), 0.0);
      for (size_t i = 0; i < p_.r.size(); ++i) {
        if (p_.fold[i] == test) continue;
        const double g = p_.g[i][c_];
        a[p_.texel[i]] += g * g;
        c[p_.texel[i]] += g * (p_.r[i][c_] - ks * s[i]);
      }
      for (size_t i = 0; i < p_.r.size(); ++i) {
        if (p_.fold[i] != test || !(a[p_.texel[i]] > 0.0)) continue;
        const double kd = std::max(0.0, c[p_.texel[i]] / a[p_.texel[i]]);
        const double e = p_.r[i][c_] - kd * p_.g[i][c_] - ks * s[i];
        sse += e * e;
        ++*count;
      }
    }
    return *count > 0 ? sse / static_cast<double>(*count) : 0.0;
  }

 private:
  // S_i(ke) of channel c.
  double Specular(size_t i, double ke) const {
    double s = 0.0;
    for (uint64_t j = p_.begin[i]; j < p_.begin[i + 1]; ++j) s += p_.w[j][c_] * std::exp(ke * p_.log_h[j]);
    return s;
  }
  struct Sums {
    double a = 0.0, b = 0.0, c = 0.0, ss = 0.0, sr = 0.0, rr = 0.0;
  };
  const Prepared& p_;
  const int c_;
  const double ks_max_;
  std::vector<Sums> sums_;
};

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
    ChannelProblem problem(p, c, options.ks_max * albedo_scale);
    const double ke0 = std::clamp(initial[c].ke, options.ke_min, options.ke_max);
    const ChannelProblem::Evaluation at_initial = problem.Evaluate(ke0, std::max(0.0, initial[c].ks));
    out.initial_cost = at_initial.cost;
    out.cost = at_initial.cost;
    // Grid over ln ke.
    std::vector<double> u(static_cast<size_t>(options.grid_points));
    std::vector<ChannelProblem::Evaluation> e(u.size());
    size_t best = 0;
    for (size_t j = 0; j < u.size(); ++j) {
      u[j] = lo + (hi - lo) * static_cast<double>(j) / static_cast<double>(u.size() - 1);
      e[j] = problem.Evaluate(std::exp(u[j]));
      if (e[j].cost < e[best].cost) best = j;
    }
    double best_u = u[best];
    ChannelProblem::Evaluation best_e = e[best];
    // Golden section between the best point's neighbours.
    double a = u[best == 0 ? 0 : best - 1], b = u[std::min(best + 1, u.size() - 1)];
    const double phi = 0.5 * (std::sqrt(5.0) - 1.0);
    double x1 = b - phi * (b - a), x2 = a + phi * (b - a);
    ChannelProblem::Evaluation f1 = problem.Evaluate(std::exp(x1)), f2 = problem.Evaluate(std::exp(x2));
    for (int it = 0; it < options.golden_iterations; ++it) {
      if (f1.cost < f2.cost) {
        b = x2;
        x2 = x1;
        f2 = f1;
        x1 = b - phi * (b - a);
        f1 = problem.Evaluate(std::exp(x1));
      } else {
        a = x1;
        x1 = x2;
        f1 = f2;
        x2 = a + phi * (b - a);
        f2 = problem.Evaluate(std::exp(x2));
      }
    }
    if (f1.cost < best_e.cost) best_u = x1, best_e = f1;
    if (f2.cost < best_e.cost) best_u = x2, best_e = f2;
    if (best_e.information < options.min_information || !(best_e.cost <= at_initial.cost) ||
        !std::isfinite(best_e.ks)) {
      continue;  // the data does not inform the lobe beyond the texels' own kd
    }
    // Kept only when it predicts the other frames at least as well as the
    // initial lobe (both with per-texel kd from the fitted frames).
    size_t held_out_count = 0;
    out.held_out_error_initial = problem.HeldOutError(std::max(0.0, initial[c].ks), ke0, &held_out_count);
    out.held_out_error = problem.HeldOutError(best_e.ks, std::exp(best_u), &held_out_count);
    if (held_out_count > 0 && !(out.held_out_error <= out.held_out_error_initial)) continue;
    out.ks = best_e.ks;
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
