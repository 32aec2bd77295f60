// Per-element diffuse albedo by closed-form least squares after removing a
// fixed specular part (thesis Eq. 6.6): for element e and channel c,
//
//   kd_ec = sum_i G_ic (r_ic - s_ic) / sum_i G_ic^2
//
// over its samples i, with G the diffuse illumination and s = ks sum I h^ke.
// The sums are accumulated in one streaming pass (samples need not be kept);
// the residual sum of squares follows from the same sums, so the errors come
// for free:  sum (r - s - kd G)^2 = S_rr - 2 kd S_rg + kd^2 S_gg.
#ifndef MVBRDF_CORE_FIT_DIFFUSE_H_
#define MVBRDF_CORE_FIT_DIFFUSE_H_

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "core/fit/phong_fit.h"
#include "core/samples/sample_set.h"

namespace mvbrdf::fit {

// Every threshold is relative to the data's own scale (issue #13), so that
// scaling every light intensity by s scales kd by exactly 1/s and changes
// nothing else: with g2 = mean G^2 over all observations of all elements
// and A = sqrt(sum S_rr / sum S_gg) (the data's albedo scale), per channel.
struct DiffuseOptions {
  // kd is clamped to [0, kd_max A].
  double kd_max = 10.0;
  // Elements whose sum G^2 (per channel) is below min_illumination g2 have
  // no usable diffuse information: kd falls back (DiffuseAccumulator::Solve).
  double min_illumination = 1e-8;
  // Shrinkage towards the fallback (e.g. the cluster's kd) where one is
  // given: kd = (S_rg + lambda kd_fallback) / (S_gg + lambda) with lambda =
  // prior_weight g2: prior_weight pseudo-observations at the data's typical
  // illumination. 0 is the thesis's plain least squares. A texel observed n
  // times at typical illumination moves prior_weight / (n + prior_weight) of
  // the way towards the fallback; one that only ever saw grazing or
  // mislabelled (shadow-boundary) light, with tiny S_gg, is held near the
  // cluster's kd instead of running to kd_max.
  double prior_weight = 0.0;
  // Robust loss (issue #14, SolveDiffuse): sigma per channel from the
  // residuals of the least-squares kd of every element (one scale for all
  // elements: a triangle or texel has too few Samples for its own), then
  // IRLS. The errors (mse, E_d) stay plain mean squared errors of the final
  // kd, so they compare with least-squares ones.
  RobustOptions robust;
};

struct DiffuseSolution {
  std::vector<glm::vec3> kd;       // per element, in [0, kd_max]
  std::vector<uint32_t> samples;   // per element
  std::vector<float> mse;          // per element, mean over its samples and channels
  std::vector<uint8_t> fallback;   // 1 where kd took the fallback value
  // Thesis E_d (Eq. 6.8): mean over elements with samples of their mse.
  double mean_element_mse = 0.0;
  uint32_t elements_with_samples = 0;
  // Robust solves: sigma per channel (units of the reflectance) and the
  // fraction of observations beyond 3 sigma (of all channels).
  glm::dvec3 robust_scale{0.0};
  double outlier_fraction = 0.0;
};

// Accumulates per element: S_gg, S_rg, S_rr per channel, and the count.
// Not thread-safe; one per thread and Merge().
class DiffuseAccumulator {
 public:
  explicit DiffuseAccumulator(size_t num_elements);
  // `residual` = r - s (reflectance minus the specular part), `illumination` = G.
  void Add(uint32_t element, const glm::vec3& residual, const glm::vec3& illumination);
  void Merge(const DiffuseAccumulator& other);
  // `fallback` per element (e.g. the cluster's kd) where the data has no
  // diffuse information; zero when empty.
  DiffuseSolution Solve(const DiffuseOptions& options, const std::vector<glm::vec3>& fallback = {}) const;
  size_t num_elements() const { return count_.size(); }
  uint32_t count(uint32_t element) const { return count_[element]; }
  // The data's scale per channel (DiffuseOptions): g2 = mean G^2 of an
  // observation, albedo = sqrt(sum S_rr / sum S_gg); 1 where undefined.
  struct DataScale {
    glm::dvec3 g2{1.0}, albedo{1.0};
  };
  DataScale ScaleOf() const;
  // The plain sums' errors (mse, E_d) of `kd` (e.g. a robust solve's) in
  // place of those of `solution`'s own kd.
  void Rescore(DiffuseSolution* solution) const;
  // Element e's estimate so far, per channel (S_rg + lambda prior) /
  // (S_gg + lambda); `prior` where there is nothing yet (issue #14: the
  // reference of a streamed robust pass).
  glm::dvec3 Running(uint32_t element, const glm::vec3& prior, const glm::dvec3& lambda) const {
    glm::dvec3 out;
    for (int c = 0; c < 3; ++c) {
      const double den = s_gg_[element][c] + lambda[c];
      out[c] = den > 0.0 ? (s_rg_[element][c] + lambda[c] * prior[c]) / den : prior[c];
    }
    return out;
  }

 private:
  std::vector<glm::dvec3> s_gg_, s_rg_, s_rr_;
  std::vector<uint32_t> count_;
};

// Convenience over a SampleSet: the specular part of `specular` (its ks, ke;
// kd ignored) removed, per-element kd solved for the lights in `mask`. With
// `threads` > 1 the elements are split among threads; the result is the same
// bit for bit.
DiffuseSolution SolveDiffuse(const samples::SampleSet& set, const samples::LightSelection& mask,
                             const PhongRgb& specular, size_t num_elements, const DiffuseOptions& options,
                             int threads = 1);

}  // namespace mvbrdf::fit

#endif  // MVBRDF_CORE_FIT_DIFFUSE_H_
