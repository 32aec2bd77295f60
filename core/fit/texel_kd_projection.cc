#include "core/fit/texel_kd_projection.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace mvbrdf::fit::internal {

std::vector<uint32_t> DenseTexels(const std::vector<uint32_t>& elements, size_t* num_texels) {
  std::vector<uint32_t> unique = elements;
  std::sort(unique.begin(), unique.end());
  unique.erase(std::unique(unique.begin(), unique.end()), unique.end());
  *num_texels = unique.size();
  std::vector<uint32_t> texel(elements.size());
  for (size_t i = 0; i < elements.size(); ++i) {
    texel[i] = static_cast<uint32_t>(std::lower_bound(unique.begin(), unique.end(), elements[i]) - unique.begin());
  }
  return texel;
}

TexelKdProblem::TexelKdProblem(const std::vector<uint32_t>& texel, const std::vector<uint8_t>& fold,
                               size_t num_texels, std::vector<double> r, double p0_max, Regressors regressors)
    : texel_(texel),
      fold_(fold),
      r_(std::move(r)),
      p0_max_(p0_max),
      regressors_(std::move(regressors)),
      sums_(num_texels) {}

TexelKdProblem::Evaluation TexelKdProblem::Evaluate(double shape, double fixed_p0) {
  regressors_(shape, &g_, &s1_, &s0_);
  std::fill(sums_.begin(), sums_.end(), Sums{});
  for (size_t i = 0; i < r_.size(); ++i) {
    const double g = g_[i], s = s1_[i], r = r_[i] - s0_[i];
    Sums& t = sums_[texel_[i]];
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

double TexelKdProblem::HeldOutError(double p0, double shape, size_t* count) {
  regressors_(shape, &g_, &s1_, &s0_);
  double sse = 0.0;
  *count = 0;
  std::vector<double> a(sums_.size()), c(sums_.size());
  for (uint8_t test = 0; test < 2; ++test) {
    std::fill(a.begin(), a.end(), 0.0);
    std::fill(c.begin(), c.end(), 0.0);
    for (size_t i = 0; i < r_.size(); ++i) {
      if (fold_[i] == test) continue;
      a[texel_[i]] += g_[i] * g_[i];
      c[texel_[i]] += g_[i] * (r_[i] - s0_[i] - p0 * s1_[i]);
    }
    for (size_t i = 0; i < r_.size(); ++i) {
      if (fold_[i] != test || !(a[texel_[i]] > 0.0)) continue;
      const double kd = std::max(0.0, c[texel_[i]] / a[texel_[i]]);
      const double e = r_[i] - s0_[i] - kd * g_[i] - p0 * s1_[i];
      sse += e * e;
      ++*count;
    }
  }
  return *count > 0 ? sse / static_cast<double>(*count) : 0.0;
}

TexelKdProblem::Search TexelKdProblem::SearchShape(double lo, double hi, int grid_points, int golden_iterations,
                                                   const std::function<double(double)>& shape_of,
                                                   const std::function<double(double)>& penalty) {
  // The cost compared: the Evaluation's plus the penalty at u.
  const auto at = [&](double u) {
    Evaluation e = Evaluate(shape_of(u));
    if (penalty) e.cost += penalty(u);
    return e;
  };
  Search best;
  const size_t n = static_cast<size_t>(std::max(grid_points, 2));
  std::vector<double> u(n);
  size_t best_j = 0;
  for (size_t j = 0; j < n; ++j) {
    u[j] = lo + (hi - lo) * static_cast<double>(j) / static_cast<double>(n - 1);
    const Evaluation e = at(u[j]);
    if (j == 0 || e.cost < best.at.cost) best_j = j, best.at = e;
  }
  best.u = u[best_j];
  double a = u[best_j == 0 ? 0 : best_j - 1], b = u[std::min(best_j + 1, n - 1)];
  const double phi = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = b - phi * (b - a), x2 = a + phi * (b - a);
  Evaluation f1 = at(x1), f2 = at(x2);
  for (int it = 0; it < golden_iterations; ++it) {
    if (f1.cost < f2.cost) {
      b = x2;
      x2 = x1;
      f2 = f1;
      x1 = b - phi * (b - a);
      f1 = at(x1);
    } else {
      a = x1;
      x1 = x2;
      f1 = f2;
      x2 = a + phi * (b - a);
      f2 = at(x2);
    }
  }
  if (f1.cost < best.at.cost) best.u = x1, best.at = f1;
  if (f2.cost < best.at.cost) best.u = x2, best.at = f2;
  if (penalty) best.at.cost -= penalty(best.u);
  return best;
}

}  // namespace mvbrdf::fit::internal
