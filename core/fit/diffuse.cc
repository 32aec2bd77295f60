// Per element e and channel c, with sums over its samples i and d_i = r_i - s_i:
//
//   S_gg = sum G_i^2,   S_rg = sum d_i G_i,   S_rr = sum d_i^2
//   kd   = clamp(S_rg / S_gg, 0, kd_max)        (fallback where S_gg < min_illumination)
//   SSE  = sum (d_i - kd G_i)^2 = S_rr - 2 kd S_rg + kd^2 S_gg
//
// The SSE form cancels catastrophically when the fit is good (it is a small
// difference of large sums, accumulated in double): it is clamped at 0, so
// an exact fit reports an error of the order of 1e-16 * S_rr, never a
// negative one.
#include "core/fit/diffuse.h"

#include <algorithm>
#include <thread>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "core/fit/phong_terms.h"

namespace mvbrdf::fit {
namespace {

// Programmer invariants (not input errors).
void Require(bool condition, const char* message) {
  if (!condition) {
    std::fprintf(stderr, "%s\n", message);
    std::abort();
  }
}

// Elements with fewer observations say little about the residual scale (one
// observation fits exactly).
constexpr double kMinScaleObservations = 3.0;

}  // namespace

DiffuseAccumulator::DiffuseAccumulator(size_t num_elements)
    : s_gg_(num_elements, glm::dvec3(0.0)),
      s_rg_(num_elements, glm::dvec3(0.0)),
      s_rr_(num_elements, glm::dvec3(0.0)),
      count_(num_elements, 0) {}

void DiffuseAccumulator::Add(uint32_t element, const glm::vec3& residual, const glm::vec3& illumination) {
  Require(element < count_.size(), "DiffuseAccumulator::Add: element out of range");
  const glm::dvec3 d(residual), g(illumination);
  s_gg_[element] += g * g;
  s_rg_[element] += d * g;
  s_rr_[element] += d * d;
  ++count_[element];
}

void DiffuseAccumulator::Merge(const DiffuseAccumulator& other) {
  Require(other.count_.size() == count_.size(), "DiffuseAccumulator::Merge: element counts differ");
  for (size_t e = 0; e < count_.size(); ++e) {
    s_gg_[e] += other.s_gg_[e];
    s_rg_[e] += other.s_rg_[e];
    s_rr_[e] += other.s_rr_[e];
    count_[e] += other.count_[e];
  }
}

DiffuseAccumulator::DataScale DiffuseAccumulator::ScaleOf() const {
  glm::dvec3 gg(0.0), rr(0.0);
  double n = 0.0;
  for (size_t e = 0; e < count_.size(); ++e) {
    gg += s_gg_[e];
    rr += s_rr_[e];
    n += count_[e];
  }
  DataScale scale;
  for (int c = 0; c < 3; ++c) {
    const double g2 = n > 0.0 ? gg[c] / n : 0.0;
    scale.g2[c] = g2 > 0.0 && std::isfinite(g2) ? g2 : 1.0;
    const double albedo = gg[c] > 0.0 ? std::sqrt(rr[c] / gg[c]) : 0.0;
    scale.albedo[c] = albedo > 0.0 && std::isfinite(albedo) ? albedo : 1.0;
  }
  return scale;
}

DiffuseSolution DiffuseAccumulator::Solve(const DiffuseOptions& options, const std::vector<glm::vec3>& fallback) const {
  Require(fallback.empty() || fallback.size() == count_.size(), "DiffuseAccumulator::Solve: fallback size differs");
  const size_t num = count_.size();
  DiffuseSolution solution;
  solution.kd.resize(num);
  solution.samples = count_;
  solution.mse.assign(num, 0.0f);
  solution.fallback.assign(num, 0);
  const DataScale scale = ScaleOf();
  double mse_sum = 0.0;
  for (size_t e = 0; e < num; ++e) {
    double sse = 0.0;
    for (int c = 0; c < 3; ++c) {
      double kd;
      const double kd_max = options.kd_max * scale.albedo[c];
      if (s_gg_[e][c] >= options.min_illumination * scale.g2[c] && s_gg_[e][c] > 0.0) {
        // With a prior: lambda pseudo-observations of the fallback at the
        // data's typical illumination (mean G^2 of an observation).
        const double lambda = fallback.empty() ? 0.0 : options.prior_weight * scale.g2[c];
        const double prior = lambda > 0.0 ? lambda * static_cast<double>(fallback[e][c]) : 0.0;
        kd = std::clamp((s_rg_[e][c] + prior) / (s_gg_[e][c] + lambda), 0.0, kd_max);
      } else {
        kd = fallback.empty() ? 0.0 : std::clamp(static_cast<double>(fallback[e][c]), 0.0, kd_max);
        solution.fallback[e] = 1;
      }
      if (!std::isfinite(kd)) kd = 0.0;
      solution.kd[e][c] = static_cast<float>(kd);
      sse += std::max(0.0, s_rr_[e][c] - 2.0 * kd * s_rg_[e][c] + kd * kd * s_gg_[e][c]);
    }
    if (count_[e] > 0) {
      const double mse = sse / (3.0 * count_[e]);
      solution.mse[e] = static_cast<float>(mse);
      mse_sum += mse;
      ++solution.elements_with_samples;
    }
  }
  solution.mean_element_mse = solution.elements_with_samples > 0 ? mse_sum / solution.elements_with_samples : 0.0;
  return solution;
}

void DiffuseAccumulator::Rescore(DiffuseSolution* solution) const {
  Require(solution->kd.size() == count_.size(), "DiffuseAccumulator::Rescore: element counts differ");
  double mse_sum = 0.0;
  solution->elements_with_samples = 0;
  for (size_t e = 0; e < count_.size(); ++e) {
    solution->samples[e] = count_[e];
    if (count_[e] == 0) continue;
    double sse = 0.0;
    for (int c = 0; c < 3; ++c) {
      const double kd = solution->kd[e][c];
      sse += std::max(0.0, s_rr_[e][c] - 2.0 * kd * s_rg_[e][c] + kd * kd * s_gg_[e][c]);
    }
    const double mse = sse / (3.0 * count_[e]);
    solution->mse[e] = static_cast<float>(mse);
    mse_sum += mse;
    ++solution->elements_with_samples;
  }
  solution->mean_element_mse = solution->elements_with_samples > 0 ? mse_sum / solution->elements_with_samples : 0.0;
}

DiffuseSolution SolveDiffuse(const samples::SampleSet& set, const samples::LightSelection& mask,
                             const PhongRgb& specular, size_t num_elements, const DiffuseOptions& options,
                             int threads) {
  const size_t num_lights = static_cast<size_t>(set.num_lights());
  std::vector<uint8_t> in_mask(num_lights, 0);
  for (size_t k = 0; k < num_lights; ++k) in_mask[k] = mask.config.Test(k) ? 1 : 0;
  const bool same_exponent = specular[0].ke == specular[1].ke && specular[0].ke == specular[2].ke;
  const glm::dvec3 ks(specular[0].ks, specular[1].ks, specular[2].ks);
  // Sample i's r - s and G; false where it is not finite.
  const auto observation = [&](size_t i, glm::vec3* residual, glm::vec3* illumination_out) {
    const glm::vec3& r = set.reflectance[i];
    if (!std::isfinite(r.x) || !std::isfinite(r.y) || !std::isfinite(r.z)) return false;
    glm::dvec3 illumination(0.0), spec(0.0);
    const bool own = mask.Own(set.frame[i]);  // every term counts
    for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) {
      const int k = set.light[j];
      if (!own && !in_mask[static_cast<size_t>(k)]) continue;
      if (!std::isfinite(set.g[j]) || !std::isfinite(set.h[j])) return false;
      const double g = internal::ClampedCosine(set.g[j]);
      if (g == 0.0) continue;
      const double h = internal::ClampedHighlight(g, set.h[j]);
      const glm::dvec3 intensity(set.light_intensity[k]);
      illumination += intensity * g;
      if (h > 0.0) {
        // Fall-off is folded into g but not into h (SampleSet::falloff).
        const double a = set.TermFalloff(j);
        if (same_exponent) {
          spec += a * intensity * internal::SpecularPower(h, specular[0].ke);
        } else {
          const double log_h = internal::LogHighlight(h);
          for (int c = 0; c < 3; ++c) {
            spec[c] += a * intensity[c] * internal::SpecularPowerOfLog(h, log_h, specular[c].ke);
          }
        }
      }
    }
    *residual = glm::vec3(glm::dvec3(r) - ks * spec);
    *illumination_out = glm::vec3(illumination);
    return true;
  };
  const uint32_t parts = static_cast<uint32_t>(std::clamp(threads, 1, 64));
  // work(part) for part in [0, parts), on threads when there are several.
  const auto in_parts = [parts](const auto& work) {
    if (parts == 1) {
      work(0u);
      return;
    }
    std::vector<std::thread> pool;
    for (uint32_t t = 0; t < parts; ++t) pool.emplace_back(work, t);
    for (std::thread& t : pool) t.join();
  };
  // A robust solve visits every Sample in 5 + iterations passes (the
  // least-squares sums, sigma's three channels, each reweighting, the
  // outliers), and its r - s and G do not change between them (ln and exp of every
  // highlight term): taken once here, in contiguous blocks of Samples on the
  // threads, and read back (the same values bit for bit).
  std::vector<glm::vec3> kept_residual, kept_illumination;
  std::vector<uint8_t> kept_ok;
  if (options.robust.enabled()) {
    kept_residual.resize(set.size());
    kept_illumination.resize(set.size());
    kept_ok.resize(set.size());
    const size_t per = (set.size() + parts - 1) / parts;
    const auto take = [&](uint32_t part) {
      const size_t first = static_cast<size_t>(part) * per, last = std::min(set.size(), first + per);
      for (size_t i = first; i < last; ++i) kept_ok[i] = observation(i, &kept_residual[i], &kept_illumination[i]);
    };
    in_parts(take);
  }
  const auto observed = [&](size_t i, glm::vec3* residual, glm::vec3* illumination) {
    if (kept_ok.empty()) return observation(i, residual, illumination);
    if (!kept_ok[i]) return false;
    *residual = kept_residual[i];
    *illumination = kept_illumination[i];
    return true;
  };
  // Element e's Sample i: r - s and G (false where it is not finite or e is
  // not an element of this solve).
  const auto element_observation = [&](size_t i, glm::vec3* d, glm::vec3* g) {
    return set.element[i] < num_elements && observed(i, d, g);
  };
  // The IRLS weights (robust passes) at the residuals of `at`, per channel.
  glm::dvec3 sigma(0.0);
  const auto weight_of = [&](const glm::vec3& residual) {
    glm::vec3 w;
    for (int c = 0; c < 3; ++c) w[c] = static_cast<float>(options.robust.Weight(residual[c] / sigma[c]));
    return w;
  };
  // Thread t takes a contiguous block of elements (no shared cache lines in
  // the accumulator), each element's Samples in their order: the sums, and so
  // the solution, are those of one thread bit for bit. `at` (robust passes):
  // the previous solve, whose residuals give the IRLS weights, folded in as
  // sqrt(w) (taken here rather than stored: one pass per reweighting).
  const size_t block = (num_elements + parts - 1) / parts;
  const auto accumulate = [&](const DiffuseSolution* at) {
    DiffuseAccumulator accumulator(num_elements);
    const auto work = [&](uint32_t part) {
      const size_t first = static_cast<size_t>(part) * block, last = std::min(num_elements, first + block);
      for (size_t i = 0; i < set.size(); ++i) {
        const uint32_t element = set.element[i];
        if (element < first || element >= last) continue;  // not part of this solve / thread
        glm::vec3 d, g;
        if (!observed(i, &d, &g)) continue;
        if (at != nullptr) {
          const glm::vec3 root = glm::sqrt(weight_of(d - at->kd[element] * g));
          d *= root;
          g *= root;
        }
        accumulator.Add(element, d, g);
      }
    };
    in_parts(work);
    return accumulator;
  };
  const DiffuseAccumulator plain = accumulate(nullptr);
  DiffuseSolution solution = plain.Solve(options);
  if (!options.robust.enabled()) return solution;

  // Residuals of the least-squares kd; sigma per channel over all of them.
  std::vector<double> values;
  values.reserve(set.size());
  for (int c = 0; c < 3; ++c) {
    values.clear();
    for (size_t i = 0; i < set.size(); ++i) {
      // Elements with n >= 3 observations; a least-squares residual is
      // sqrt((n - 1) / n) of the noise's on average (one parameter fitted).
      glm::vec3 d, g;
      if (!element_observation(i, &d, &g)) continue;
      const uint32_t element = set.element[i];
      const double n = solution.samples[element];
      if (n >= kMinScaleObservations) {
        const glm::vec3 residual = d - solution.kd[element] * g;
        values.push_back(residual[c] * std::sqrt(n / (n - 1.0)));
      }
    }
    sigma[c] = MadScale(&values);
  }
  values = std::vector<double>();
  solution.robust_scale = sigma;
  if (!(sigma.x > 0.0 && sigma.y > 0.0 && sigma.z > 0.0)) return solution;  // an exact fit
  for (int it = 0; it < options.robust.iterations; ++it) {
    DiffuseSolution next = accumulate(&solution).Solve(options);
    next.robust_scale = solution.robust_scale;
    next.outlier_fraction = solution.outlier_fraction;
    solution = std::move(next);
  }
  // Outliers: observations beyond 3 sigma of the final kd (any channel counts once per channel).
  size_t outliers = 0, observations = 0;
  for (size_t i = 0; i < set.size(); ++i) {
    glm::vec3 d, g;
    if (!element_observation(i, &d, &g)) continue;
    const glm::vec3 residual = d - solution.kd[set.element[i]] * g;
    for (int c = 0; c < 3; ++c) {
      ++observations;
      outliers += std::fabs(residual[c]) > 3.0 * sigma[c] ? 1 : 0;
    }
  }
  solution.outlier_fraction =
      observations > 0 ? static_cast<double>(outliers) / static_cast<double>(observations) : 0.0;
  plain.Rescore(&solution);
  return solution;
}

}  // namespace mvbrdf::fit
