#include "core/fit/lobe_texel_kd_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/brdf/ggx.h"

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

// One channel at one shape: the regressors of every Sample, then the
// variable-projection solve.
class ChannelProblem {
 public:
  ChannelProblem(BrdfModel model, const Prepared& p, const std::vector<glm::vec3>& intensity, int c, double p0_max)
      : model_(model), p_(p), intensity_(intensity), c_(c), p0_max_(p0_max), sums_(p.num_texels) {}

  struct Evaluation {
    double p0 = 0.0;
    double cost = 0.0;
    double information = 0.0;
    double kd = 0.0;  // the cluster's kd
  };

  // At `shape` with p0 solved (fixed_p0 < 0) or given.
  Evaluation Evaluate(double shape, double fixed_p0 = -1.0) {
    Regressors(shape);
    std::fill(sums_.begin(), sums_.end(), Sums{});
    for (size_t i = 0; i < p_.r.size(); ++i) {
      const double g = g_[i], s = s1_[i], r = p_.r[i][c_] - s0_[i];
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
    e.p0 = fixed_p0 >= 0.0 ? fixed_p0 : (den > 0.0 ? std::clamp(num / den, 0.0, p0_max_) : 0.0);
    double cost = 0.0, ga = 0.0, gc = 0.0;
    for (const Sums& t : sums_) {
      const double kd = t.a > 0.0 ? std::max(0.0, (t.c - e.p0 * t.b) / t.a) : 0.0;
      cost += t.rr - 2.0 * kd * t.c - 2.0 * e.p0 * t.sr + kd * kd * t.a + 2.0 * kd * e.p0 * t.b + e.p0 * e.p0 * t.ss;
      ga += t.a;
      gc += t.c - e.p0 * t.b;
    }
    e.cost = 0.5 * std::max(0.0, cost);
    e.kd = ga > 0.0 ? std::max(0.0, gc / ga) : 0.0;
    return e;
  }

  // Mean squared error on held-out frames (see texel_kd_fit.h's), `count` Samples.
  double HeldOutError(double p0, double shape, size_t* count) {
    Regressors(shape);
    double sse = 0.0;
    *count = 0;
    std::vector<double> a(p_.num_texels), c(p_.num_texels);
    for (uint8_t test = 0; test < 2; ++test) {
      std::fill(a.begin(), a.end(), 0.0);
      std::fill(c.begin(), c.end(), 0.0);
      for (size_t i = 0; i < p_.r.size(); ++i) {
        if (p_.fold[i] == test) continue;
        a[p_.texel[i]] += g_[i] * g_[i];
        c[p_.texel[i]] += g_[i] * (p_.r[i][c_] - s0_[i] - p0 * s1_[i]);
      }
      for (size_t i = 0; i < p_.r.size(); ++i) {
        if (p_.fold[i] != test || !(a[p_.texel[i]] > 0.0)) continue;
        const double kd = std::max(0.0, c[p_.texel[i]] / a[p_.texel[i]]);
        const double e = p_.r[i][c_] - s0_[i] - kd * g_[i] - p0 * s1_[i];
        sse += e * e;
        ++*count;
      }
    }
    return *count > 0 ? sse / static_cast<double>(*count) : 0.0;
  }

 private:
  // G, S1 and S0 of every Sample at `shape`.
  void Regressors(double shape) {
    g_.assign(p_.r.size(), 0.0);
    s1_.assign(p_.r.size(), 0.0);
    s0_.assign(p_.r.size(), 0.0);
    const std::array<double, 2> zero = {0.0, shape}, one = {1.0, shape};
    for (size_t i = 0; i < p_.r.size(); ++i) {
      for (uint64_t j = p_.begin[i]; j < p_.begin[i + 1]; ++j) {
        const double intensity = intensity_[p_.light[j]][c_];
        const brdf::Geometry& geometry = p_.geometry[j];
        const double at_zero = ModelSpecular(model_, zero, geometry);
        g_[i] += intensity * ModelDiffuseWeight(model_, zero, geometry) * p_.g[j];
        s0_[i] += intensity * p_.a[j] * at_zero;
        s1_[i] += intensity * p_.a[j] * (ModelSpecular(model_, one, geometry) - at_zero);
      }
    }
  }
  struct Sums {
    double a = 0.0, b = 0.0, c = 0.0, ss = 0.0, sr = 0.0, rr = 0.0;
  };
  const BrdfModel model_;
  const Prepared& p_;
  const std::vector<glm::vec3>& intensity_;
  const int c_;
  const double p0_max_;
  std::vector<Sums> sums_;
  std::vector<double> g_, s1_, s0_;
};

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
  const auto shape_of = [&](double u) { return ggx ? u : std::exp(u); };
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
    ChannelProblem problem(model, p, set.light_intensity, c, p0_max);
    const double shape0 = ggx ? std::clamp(initial[c].p[1], lo, hi) : std::clamp(initial[c].p[1], std::exp(lo), std::exp(hi));
    const double p00 = std::clamp(initial[c].p[0], 0.0, p0_max);
    const ChannelProblem::Evaluation at_initial = problem.Evaluate(shape0, p00);
    std::vector<double> u(static_cast<size_t>(options.grid_points));
    size_t best = 0;
    ChannelProblem::Evaluation best_e;
    for (size_t j = 0; j < u.size(); ++j) {
      u[j] = lo + (hi - lo) * static_cast<double>(j) / static_cast<double>(u.size() - 1);
      const ChannelProblem::Evaluation e = problem.Evaluate(shape_of(u[j]));
      if (j == 0 || e.cost < best_e.cost) best = j, best_e = e;
    }
    double best_u = u[best];
    double a = u[best == 0 ? 0 : best - 1], b = u[std::min(best + 1, u.size() - 1)];
    const double phi = 0.5 * (std::sqrt(5.0) - 1.0);
    double x1 = b - phi * (b - a), x2 = a + phi * (b - a);
    ChannelProblem::Evaluation f1 = problem.Evaluate(shape_of(x1)), f2 = problem.Evaluate(shape_of(x2));
    for (int it = 0; it < options.golden_iterations; ++it) {
      if (f1.cost < f2.cost) {
        b = x2;
        x2 = x1;
        f2 = f1;
        x1 = b - phi * (b - a);
        f1 = problem.Evaluate(shape_of(x1));
      } else {
        a = x1;
        x1 = x2;
        f1 = f2;
        x2 = a + phi * (b - a);
        f2 = problem.Evaluate(shape_of(x2));
      }
    }
    if (f1.cost < best_e.cost) best_u = x1, best_e = f1;
    if (f2.cost < best_e.cost) best_u = x2, best_e = f2;
    if (best_e.information < options.min_information || !(best_e.cost <= at_initial.cost) ||
        !std::isfinite(best_e.p0)) {
      continue;
    }
    size_t count = 0;
    result.held_out_error_initial[c] = problem.HeldOutError(p00, shape0, &count);
    result.held_out_error[c] = problem.HeldOutError(best_e.p0, shape_of(best_u), &count);
    if (count > 0 && !(result.held_out_error[c] <= result.held_out_error_initial[c])) continue;
    result.params[c] = {best_e.kd, {best_e.p0, shape_of(best_u)}};
    result.refined[c] = true;
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace mvbrdf::fit
