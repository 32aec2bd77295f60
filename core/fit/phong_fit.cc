// FitPhong: the data is made scale-free per channel before either solver sees
// it, so that tolerances mean the same for intensities of 1e-6 and 1e6:
//
//   I_max   = max_{k in mask} I_kc          w_k = I_kc / I_max
//   r_scale = sqrt(mean_i r_ic^2)           (1 when all r are 0)
//   a = kd I_max / r_scale,  b = ks I_max / r_scale,  t = ln ke
//
// so r / r_scale = a G' + b S'(t) with G', S' built from w (phong_cost.h).
// kd = a r_scale / I_max and ks likewise on the way out; ke is unchanged.
//
// Bounds: [0, kd_max A], [0, ks_max A], [ln ke_min, ln ke_max], with A the
// data's albedo scale (r_rms / G_rms, see SetUpChannel); kd_max, ks_max and the
// initial kd, ks are multiples of A, so no bound or starting point assumes
// data in [0, 1]. The LM (phong_lm.h) enforces them by projecting each step
// onto the box. Powell minimises C(P(x)) with P the clamp to the box (a projection:
// continuous, piecewise smooth, flat outside the box), and the iterate is
// projected back after each line minimisation; the bounds are reachable
// exactly (ks = 0 for a diffuse surface), which a sigmoid map would not allow.
#include "core/fit/phong_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/vector_exp.h"
#include "core/fit/phong_cost.h"
#include "core/fit/phong_lm.h"
#include "core/fit/phong_terms.h"
#include "core/fit/powell.h"

namespace mvbrdf::fit {
namespace {

using internal::kNoHighlight;
using internal::PhongChannelData;
using samples::LightMask;
using samples::LightSelection;
using samples::SampleSet;

// A fitted parameter within this fraction of its range from a bound is at it.
constexpr double kAtBoundFraction = 1e-6;
// The LM's parameter tolerance (relative step size to stop; Ceres's default).
constexpr double kParameterTolerance = 1e-10;

bool IsFinite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// The samples of one fit restricted to the lights of the mask; shared by the
// three channels. Per used sample its terms (CSR, like SampleSet's): the lit
// ones (g > 0) for the diffuse sum, the highlight ones (h > 0) for the cost.
struct PreparedSamples {
  std::vector<int> lights;     // light index per mask slot
  std::vector<uint32_t> used;  // sample indices whose inputs are finite
  std::vector<uint64_t> g_begin = {0};
  std::vector<uint16_t> g_slot;
  std::vector<double> g;          // clamped cosines
  internal::PhongTerms specular;  // ln h (and ln a) of the terms with h > 0
  bool non_finite = false;        // some sample was skipped
  std::vector<int> slot_of;       // scratch: mask slot per light, -1 if none

  void Clear() {
    lights.clear();
    used.clear();
    g_begin.assign(1, 0);
    g_slot.clear();
    g.clear();
    specular.Clear();
    non_finite = false;
  }
  size_t CapacityBytes() const {
    return (lights.capacity() + slot_of.capacity()) * sizeof(int) + used.capacity() * sizeof(uint32_t) +
           g_begin.capacity() * sizeof(uint64_t) + g_slot.capacity() * sizeof(uint16_t) +
           g.capacity() * sizeof(double) + specular.CapacityBytes();
  }
};

// Fills `prep` (emptied first; its arrays' memory is reused).
void Prepare(const SampleSet& set, const std::vector<uint32_t>& indices, const LightSelection& selection,
             PreparedSamples* out) {
  PreparedSamples& prep = *out;
  prep.Clear();
  const int num_lights = set.num_lights();
  const size_t count = indices.empty() ? set.size() : indices.size();
  // Slots for the configuration's lights and every light of a frame with its
  // own lights (LightSelection).
  LightMask mask = selection.config;
  for (size_t u = 0; u < count && !selection.own.empty(); ++u) {
    const size_t i = indices.empty() ? u : indices[u];
    if (!selection.Own(set.frame[i])) continue;
    for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) mask.Set(set.light[j]);
  }
  std::vector<int>& slot_of = prep.slot_of;
  slot_of.assign(static_cast<size_t>(num_lights), -1);
  mask.ForEach([&](size_t k) {
    if (k >= static_cast<size_t>(num_lights)) return;
    slot_of[k] = static_cast<int>(prep.lights.size());
    prep.lights.push_back(static_cast<int>(k));
  });
  prep.used.reserve(count);
  size_t num_terms = set.num_terms();
  if (!indices.empty()) {
    num_terms = 0;
    for (uint32_t i : indices) num_terms += set.TermsEnd(i) - set.TermsBegin(i);
  }
  prep.g_begin.reserve(count + 1);
  prep.g_slot.reserve(num_terms);
  prep.g.reserve(num_terms);
  prep.specular.begin.reserve(count + 1);
  prep.specular.slot.reserve(num_terms);
  prep.specular.log_h.reserve(num_terms);
  if (!set.falloff.empty()) prep.specular.log_a.reserve(num_terms);
  for (size_t u = 0; u < count; ++u) {
    const size_t i = indices.empty() ? u : indices[u];
    const bool own = selection.Own(set.frame[i]);
    const auto selected = [&](size_t k) { return slot_of[k] >= 0 && (own || selection.config.Test(k)); };
    bool finite = IsFinite(set.reflectance[i]);
    for (size_t j = set.TermsBegin(i); finite && j < set.TermsEnd(i); ++j) {
      finite = !selected(set.light[j]) || (std::isfinite(set.g[j]) && std::isfinite(set.h[j]));
    }
    if (!finite) {
      prep.non_finite = true;
      continue;
    }
    prep.used.push_back(static_cast<uint32_t>(i));
    for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) {
      if (!selected(set.light[j])) continue;
      const int slot = slot_of[set.light[j]];
      const double g = internal::ClampedCosine(set.g[j]);
      if (g == 0.0) continue;
      const double h = internal::ClampedHighlight(g, set.h[j]);
      prep.g_slot.push_back(static_cast<uint16_t>(slot));
      prep.g.push_back(g);
      if (!(h > 0.0)) continue;
      prep.specular.slot.push_back(static_cast<uint16_t>(slot));
      prep.specular.log_h.push_back(std::log(h));
      if (!set.falloff.empty()) {
        const double a = set.TermFalloff(j);
        prep.specular.log_a.push_back(a > 0.0 && std::isfinite(a) ? std::log(a) : kNoHighlight);
      }
    }
    prep.g_begin.push_back(prep.g.size());
    prep.specular.begin.push_back(prep.specular.slot.size());
  }
  prep.specular.Densify(static_cast<int>(prep.lights.size()));
}

struct ChannelOutcome {
  PhongChannel params;
  ChannelFitSummary summary;
  double sum_squares = 0.0;  // sum of squared residuals, original units
};

// Powell's cost C(P(x)) with S_i cached for the last exponent: the unit
// directions of kd and ks leave ke unchanged and then cost no exp().
class PowellPhongCost {
 public:
  PowellPhongCost(const PhongChannelData& data, const double* lower, const double* upper)
      : data_(data), lower_(lower), upper_(upper), specular_(data.size()) {}

  double operator()(const double* x_unclamped) {
    double x[3];
    for (int j = 0; j < 3; ++j) x[j] = std::clamp(x_unclamped[j], lower_[j], upper_[j]);
    if (!(x[2] == cached_t_)) {
      internal::SpecularSumsRange(data_, 0, data_.size(), std::exp(x[2]), specular_.data(), nullptr);
      cached_t_ = x[2];
    }
    double sum = 0.0;
    for (size_t i = 0; i < data_.size(); ++i) {
      const double rho = data_.r[i] - x[0] * data_.diffuse[i] - x[1] * specular_[i];
      sum += data_.sqrt_weight.empty() ? rho * rho : data_.sqrt_weight[i] * data_.sqrt_weight[i] * rho * rho;
    }
    return 0.5 * sum;
  }

 private:
  const PhongChannelData& data_;
  const double* lower_;
  const double* upper_;
  std::vector<double> specular_;
  double cached_t_ = std::nan("");
};

// Minimises over the free coordinates of x (phong_lm.h: one fused pass over
// the samples per step, Ceres's LM rules).
internal::PhongLmSummary SolveLevenbergMarquardt(const PhongChannelData& data, const bool* free, const double* lower,
                                                 const double* upper, const PhongFitOptions& options, double* x,
                                                 ChannelFitSummary* summary) {
  internal::PhongLmOptions lm;
  lm.max_iterations = options.max_iterations;
  lm.function_tolerance = options.function_tolerance;
  lm.parameter_tolerance = kParameterTolerance;
  const internal::PhongLmSummary result = internal::SolvePhongLm(data, free, lower, upper, lm, x);
  summary->iterations = result.iterations;
  if (!result.converged) summary->flags |= kDidNotConverge;
  return result;
}

void SolvePowell(const PhongChannelData& data, const bool* free, const double* lower, const double* upper,
                 const PhongFitOptions& options, double* x, ChannelFitSummary* summary) {
  int free_index[3];
  int n = 0;
  for (int j = 0; j < 3; ++j) {
    if (free[j]) free_index[n++] = j;
  }
  PowellPhongCost phong_cost(data, lower, upper);
  const auto cost = [&](const double* u) {
    double point[3] = {x[0], x[1], x[2]};
    for (int m = 0; m < n; ++m) point[free_index[m]] = u[m];
    return phong_cost(point);
  };
  const auto project = [&](double* u) {
    for (int m = 0; m < n; ++m) u[m] = std::clamp(u[m], lower[free_index[m]], upper[free_index[m]]);
  };
  double u[3];
  for (int m = 0; m < n; ++m) u[m] = x[free_index[m]];
  PowellOptions powell_options;
  powell_options.max_iterations = options.max_iterations;
  powell_options.function_tolerance = options.function_tolerance;
  // Restarts while they still lower the cost, within max_iterations in all
  // (PowellOptions::restarts: a restart takes at least one iteration).
  // Measured on bench-peer's mixed-ke problem: its ke = 5 and ke = 200
  // channels stopped 2.8 % and 0.46 % above the LM's cost without restarts,
  // at it (1e-12) with them. At most three restarts left a ke = 5 channel
  // 0.14 % above it, "converged" (FitPhongTest.PowellRestartsWhileTheyGain):
  // each run stopped after 4 iterations, each restart still gained.
  powell_options.restarts = options.max_iterations;
  const PowellSummary powell = MinimizePowell(cost, n, u, powell_options, project);
  for (int m = 0; m < n; ++m) x[free_index[m]] = std::clamp(u[m], lower[free_index[m]], upper[free_index[m]]);
  summary->iterations = powell.iterations;
  if (!powell.converged) summary->flags |= kDidNotConverge;
}

// The start of ks and ke, free of units: for each exponent of a log grid
// over [ke_min, ke_max], kd (when free) and ks by non-negative linear least
// squares in closed form; the exponent with the lowest cost wins. A fixed
// initial ks assumed data in [0, 1] (ks = 0.1 in absolute units), and the
// cost's local minima in ke make the start matter: from initial.ks times the
// data's albedo scale LM chose the wrong light configuration on the synth
// sequence (reconstruct_stage_test) and missed ke by 350 %.
constexpr int kInitialGrid = 25;
// Samples from which FitPhong solves its three channels on threads of their
// own (the LM solves a channel of 1e4 samples in ~0.5 ms, of 1e5 in ~5 ms:
// bench-peer's problems; Powell takes ~15x the LM's time).
constexpr size_t kParallelChannelSamples = 10000;
// The grid's sums are estimated from about this many samples: 25 exp() per
// term over all of 1e5 samples took 8x the LM's own time (scripts/bench-peer),
// and the grid only has to find the basin the LM then solves on all samples.
// Half of them are the samples nearest a mirror highlight (a sharp lobe,
// ke ~1000, is seen by a few samples only), each with weight 1; the other
// half every stride-th of the rest, with weight stride: an unbiased estimate
// of the sums over all samples.
constexpr size_t kGridSamples = 8192;

// One channel's fit: its normalised data, bounds and start (SetUpChannel),
// the grid's start for ks and ke (InitialSpecular, shared by the channels),
// then the solve (SolveChannel).
struct ChannelFit {
  PhongChannelData data;
  double r_scale = 1.0, to_original = 1.0;
  uint32_t flags = kFitOk;
  bool free[3] = {false, false, false};
  double lower[3] = {0, 0, 0}, upper[3] = {0, 0, 0};
  double x[3] = {0, 0, 0};
  bool grid() const { return free[1] && data.size() > 0; }  // ks and ke to start from the grid

  // A fresh fit that keeps the data arrays' memory.
  void Reset() {
    PhongChannelData kept;
    kept.weight.swap(data.weight);
    kept.r.swap(data.r);
    kept.diffuse.swap(data.diffuse);
    kept.sqrt_weight.swap(data.sqrt_weight);
    *this = ChannelFit();
    data.weight.swap(kept.weight);
    data.r.swap(kept.r);
    data.diffuse.swap(kept.diffuse);
    data.sqrt_weight.swap(kept.sqrt_weight);
    data.weight.clear();
    data.r.clear();
    data.diffuse.clear();
    data.sqrt_weight.clear();
  }
  size_t CapacityBytes() const {
    return (data.weight.capacity() + data.r.capacity() + data.diffuse.capacity() + data.sqrt_weight.capacity()) *
           sizeof(double);
  }
};

// InitialSpecular's arrays (kept between fits like the rest of FitWorkspace).
struct GridScratch {
  std::vector<uint32_t> chosen;
  std::vector<double> weight, nearest, sorted, exps;
  internal::PhongTerms terms;
  std::vector<double> specular[3], wr[3], wg[3];

  size_t CapacityBytes() const {
    size_t bytes = chosen.capacity() * sizeof(uint32_t) + terms.CapacityBytes() +
                   (weight.capacity() + nearest.capacity() + sorted.capacity() + exps.capacity()) * sizeof(double);
    for (int c = 0; c < 3; ++c) {
      bytes += (specular[c].capacity() + wr[c].capacity() + wg[c].capacity()) * sizeof(double);
    }
    return bytes;
  }
};

// The arrays of one FitPhong call, kept by the calling thread for its next
// call. Fresh arrays cost more than the solve: in `perf` of a 1e5-sample fit
// (fit_peer) ~85 % of the time went to mmap, page faults and munmap of the
// prepared terms and channel data, every call. Kept up to kKeepBytes, so that a
// thread that once fitted a huge cluster does not hold its arrays for the rest
// of the job.
struct FitWorkspace {
  static constexpr size_t kKeepBytes = size_t{48} << 20;
  PreparedSamples prep;
  ChannelFit fits[3];
  GridScratch grid;

  // After a fit: the arrays are kept when they are small enough.
  void Release() {
    size_t bytes = prep.CapacityBytes() + grid.CapacityBytes();
    for (const ChannelFit& fit : fits) bytes += fit.CapacityBytes();
    if (bytes <= kKeepBytes) return;
    prep = PreparedSamples();
    for (ChannelFit& fit : fits) fit = ChannelFit();
    grid = GridScratch();
  }
};

// The samples the grid's sums are estimated from, with their weights: all of
// them up to kGridSamples; beyond, the kGridSamples / 2 nearest a mirror
// highlight (largest ln h) with weight 1 and a stride through the rest with
// weight stride (unbiased sums). The same for every channel (ln h is).
void GridSamples(const PhongChannelData& data, GridScratch* scratch) {
  std::vector<uint32_t>* chosen = &scratch->chosen;
  std::vector<double>* weight = &scratch->weight;
  chosen->clear();
  weight->clear();
  const size_t n = data.size();
  if (n <= kGridSamples) {
    for (size_t i = 0; i < n; ++i) chosen->push_back(static_cast<uint32_t>(i));
    weight->assign(n, 1.0);
    return;
  }
  std::vector<double>& nearest = scratch->nearest;  // per sample its largest ln h
  nearest.assign(n, internal::kNoHighlight);
  for (size_t i = 0; i < n; ++i) {
    for (uint64_t j = data.begin[i]; j < data.begin[i + 1]; ++j) nearest[i] = std::max(nearest[i], data.log_h[j]);
  }
  std::vector<double>& sorted = scratch->sorted;
  sorted.assign(nearest.begin(), nearest.end());
  const size_t top = kGridSamples / 2;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(n - top), sorted.end());
  const double threshold = sorted[n - top];
  // Ties at the threshold go to the rest, so the top set is at most `top`.
  size_t rest = 0;
  for (size_t i = 0; i < n; ++i) rest += nearest[i] > threshold ? 0 : 1;
  const size_t stride = std::max<size_t>(1, rest / (kGridSamples - top));
  for (size_t i = 0, k = 0; i < n; ++i) {
    if (nearest[i] > threshold) {
      chosen->push_back(static_cast<uint32_t>(i));
      weight->push_back(1.0);
    } else if (k++ % stride == 0) {
      chosen->push_back(static_cast<uint32_t>(i));
      weight->push_back(static_cast<double>(stride));
    }
  }
}

// The start of ks and ke of every channel in `fits` that needs one (all fit
// the same samples with the same terms; only r, G and the light weights
// differ): for each exponent of a log grid over [ke_min, ke_max], kd (when
// free) and ks by non-negative linear least squares in closed form; the
// exponent with the lowest cost wins. The exponentials exp(ke ln h + ln a)
// of the grid's samples do not depend on the channel and are taken once per
// grid point for all of them.
void InitialSpecular(const PhongFitOptions& options, const std::vector<ChannelFit*>& fits, GridScratch* scratch) {
  if (fits.empty()) return;
  const PhongChannelData& shared = fits[0]->data;
  GridSamples(shared, scratch);
  const std::vector<uint32_t>& chosen = scratch->chosen;
  const std::vector<double>& weight = scratch->weight;
  // The chosen samples' terms, with a weight of 1 per slot (the channels'
  // weights are applied in the sums below).
  internal::PhongTerms& terms = scratch->terms;
  terms.Clear();
  size_t num_slots = 0;
  for (uint32_t i : chosen) {
    for (uint64_t j = shared.begin[i]; j < shared.begin[i + 1]; ++j) {
      terms.slot.push_back(shared.slot[j]);
      terms.log_h.push_back(shared.log_h[j]);
      if (shared.log_a != nullptr) terms.log_a.push_back(shared.log_a[j]);
      num_slots = std::max<size_t>(num_slots, shared.slot[j] + size_t{1});
    }
    terms.begin.push_back(terms.slot.size());
  }
  const size_t m = chosen.size();
  terms.Densify(static_cast<int>(num_slots));
  const bool dense = terms.dense_slots > 0;
  // Per grid point the terms' exponentials (dense: slot-major, m per slot),
  // summed per channel with the channel's weights: E_c,i = sum_k w_c,k exp(...).
  std::vector<double>& exps = scratch->exps;
  exps.resize(dense ? terms.dense_log_h.size() : terms.log_h.size());
  std::vector<double>* specular = scratch->specular;
  struct Sums {
    double rr = 0, rg = 0, gg = 0;
    double best = std::numeric_limits<double>::infinity();
  };
  Sums sums[3];
  // Per channel the chosen samples' weight * r and weight * G, contiguous.
  std::vector<double>* wr = scratch->wr;
  std::vector<double>* wg = scratch->wg;
  for (size_t f = 0; f < fits.size(); ++f) {
    specular[f].resize(m);
    wr[f].resize(m);
    wg[f].resize(m);
    const PhongChannelData& data = fits[f]->data;
    for (size_t q = 0; q < m; ++q) {
      const size_t i = chosen[q];
      sums[f].rr += weight[q] * data.r[i] * data.r[i];
      sums[f].rg += weight[q] * data.r[i] * data.diffuse[i];
      sums[f].gg += weight[q] * data.diffuse[i] * data.diffuse[i];
      wr[f][q] = weight[q] * data.r[i];
      wg[f][q] = weight[q] * data.diffuse[i];
    }
  }
  const double t_min = std::log(options.ke_min), t_max = std::log(options.ke_max);
  for (int g = 0; g < kInitialGrid; ++g) {
    const double t = t_min + (t_max - t_min) * g / (kInitialGrid - 1);
    if (dense) {
      base::ExpAffine(exps.size(), std::exp(t), terms.dense_log_h.data(), terms.dense_offset.data(), exps.data());
    } else {
      base::ExpAffine(exps.size(), std::exp(t), terms.log_h.data(), terms.log_a.empty() ? nullptr : terms.log_a.data(),
                      exps.data());
    }
    for (size_t f = 0; f < fits.size(); ++f) {
      const PhongChannelData& data = fits[f]->data;
      double* sp = specular[f].data();
      if (dense) {
        std::fill(sp, sp + m, 0.0);
        for (size_t k = 0; k < num_slots; ++k) {
          const double w = data.weight[k];
          const double* e = exps.data() + k * m;
          for (size_t q = 0; q < m; ++q) sp[q] += w * e[q];
        }
        continue;
      }
      for (size_t q = 0; q < m; ++q) {
        double sum = 0.0;
        for (uint64_t j = terms.begin[q]; j < terms.begin[q + 1]; ++j) sum += data.weight[terms.slot[j]] * exps[j];
        sp[q] = sum;
      }
    }
    for (size_t f = 0; f < fits.size(); ++f) {
      ChannelFit& fit = *fits[f];
      const bool kd_free = fit.free[0];
      double s_rs = 0.0, s_gs = 0.0, s_ss = 0.0;
      const double* sp = specular[f].data();
      const double* r = wr[f].data();
      const double* g = wg[f].data();
      for (size_t q = 0; q < m; ++q) {
        s_rs += r[q] * sp[q];
        s_gs += g[q] * sp[q];
        s_ss += weight[q] * sp[q] * sp[q];
      }
      const Sums& c = sums[f];
      const auto cost = [&](double a, double b) {
        return c.rr - 2.0 * a * c.rg - 2.0 * b * s_rs + a * a * c.gg + 2.0 * a * b * s_gs + b * b * s_ss;
      };
      // Candidates (a, b) >= 0: ks alone (kd fixed), both free, kd alone.
      std::pair<double, double> candidates[3];
      int count = 0;
      if (!kd_free && s_ss > 0.0) candidates[count++] = {fit.x[0], std::max(0.0, (s_rs - fit.x[0] * s_gs) / s_ss)};
      if (kd_free) {
        const double det = c.gg * s_ss - s_gs * s_gs;
        if (det > 0.0) {
          const double a = (c.rg * s_ss - s_rs * s_gs) / det, b = (s_rs * c.gg - c.rg * s_gs) / det;
          if (a >= 0.0 && b >= 0.0) candidates[count++] = {a, b};
        }
        if (c.gg > 0.0) candidates[count++] = {std::max(0.0, c.rg / c.gg), 0.0};
      }
      for (int k = 0; k < count; ++k) {
        const auto [a, b] = candidates[k];
        const double ca = std::clamp(a, fit.lower[0], fit.upper[0]), cb = std::clamp(b, fit.lower[1], fit.upper[1]);
        const double v = cost(ca, cb);
        if (std::isfinite(v) && v < sums[f].best) {
          sums[f].best = v;
          if (kd_free) fit.x[0] = ca;
          fit.x[1] = cb;
          fit.x[2] = t;
        }
      }
    }
  }
}

// IRLS after the least-squares solve at x: sigma from the residuals at x
// (1.4826 MAD, normalised units), then `robust.iterations` solves from the
// previous one with the loss's weights at the current residuals. The weights
// are cleared afterwards, so the costs reported are plain sums of squares.
template <typename Solve>
void RobustRefit(const RobustOptions& robust, const Solve& solve, double* x, double r_scale, PhongChannelData* data,
                 ChannelFitSummary* summary) {
  const size_t n = data->size();
  std::vector<double> rho(n), scratch;
  internal::EvaluatePhongResiduals(*data, 0, n, x, rho.data(), nullptr);
  scratch = rho;
  const double sigma = MadScale(&scratch);
  summary->robust_scale = sigma * r_scale;
  if (!(sigma > 0.0) || !std::isfinite(sigma)) return;  // an exact fit: nothing to down-weight
  data->sqrt_weight.resize(n);
  int iterations = summary->iterations;
  for (int it = 0; it < robust.iterations; ++it) {
    for (size_t i = 0; i < n; ++i) data->sqrt_weight[i] = std::sqrt(robust.Weight(rho[i] / sigma));
    solve();
    iterations += summary->iterations;
    data->sqrt_weight.clear();
    internal::EvaluatePhongResiduals(*data, 0, n, x, rho.data(), nullptr);
    data->sqrt_weight.resize(n);
  }
  data->sqrt_weight.clear();
  summary->iterations = iterations;
  size_t outliers = 0;
  for (double v : rho) outliers += std::fabs(v) > 3.0 * sigma ? 1 : 0;
  summary->outlier_fraction = static_cast<double>(outliers) / static_cast<double>(std::max<size_t>(n, 1));
}

// Channel c's normalised data, identifiability, bounds and kd's start.
void SetUpChannel(const PreparedSamples& prep, const SampleSet& set, int c, const PhongFitOptions& options,
                  ChannelFit* fit) {
  const size_t n = prep.used.size();
  PhongChannelData& data = fit->data;
  prep.specular.Attach(&data);
  double i_max = 0.0;
  for (int k : prep.lights) {
    const double intensity = set.light_intensity[k][c];
    data.weight.push_back(intensity);
    i_max = std::max(i_max, intensity);
  }
  if (i_max > 0.0) {
    for (double& w : data.weight) w /= i_max;
  }
  data.r.resize(n);
  data.diffuse.resize(n);
  double sum_rr = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const double r = set.reflectance[prep.used[i]][c];
    sum_rr += r * r;
    double g_sum = 0.0;
    for (uint64_t j = prep.g_begin[i]; j < prep.g_begin[i + 1]; ++j) g_sum += data.weight[prep.g_slot[j]] * prep.g[j];
    data.r[i] = r;
    data.diffuse[i] = g_sum;
  }
  double r_scale = n > 0 ? std::sqrt(sum_rr / static_cast<double>(n)) : 1.0;
  if (!(r_scale > 0.0) || !std::isfinite(r_scale)) r_scale = 1.0;
  for (double& r : data.r) r /= r_scale;
  fit->r_scale = r_scale;
  // kd = a * to_original, ks = b * to_original.
  fit->to_original = i_max > 0.0 ? r_scale / i_max : 1.0;

  // Identifiability.
  const double log_highlight = options.highlight_cosine > 0.0 ? std::log(options.highlight_cosine) : kNoHighlight;
  size_t diffuse_samples = 0, highlight_samples = 0;
  for (size_t i = 0; i < n; ++i) {
    if (data.diffuse[i] > options.min_cosine) ++diffuse_samples;
    for (uint64_t j = data.begin[i]; j < data.begin[i + 1]; ++j) {
      const double log_h = data.log_h[j];
      if (data.weight[data.slot[j]] > 0.0 && log_h != kNoHighlight && log_h > log_highlight) {
        ++highlight_samples;
        break;
      }
    }
  }
  uint32_t flags = prep.non_finite ? kNonFiniteInput : kFitOk;
  if (n == 0) flags |= kNoSamples;
  const bool kd_free = diffuse_samples > 0;
  const bool specular_free = highlight_samples >= static_cast<size_t>(std::max(options.min_highlight_samples, 1));
  if (!kd_free) flags |= kKdNotIdentifiable;
  if (!specular_free) flags |= kKsKeNotIdentifiable;
  fit->flags = flags;

  // The data's own albedo scale in normalised units: the a for which a G'
  // alone has the rms of r (1 in normalised units). Bounds and initial
  // values are multiples of it, so that they mean the same whatever the
  // units of the lights' intensities and of the images.
  double sum_gg = 0.0;
  for (size_t i = 0; i < n; ++i) sum_gg += data.diffuse[i] * data.diffuse[i];
  double albedo_scale = n > 0 && sum_gg > 0.0 ? std::sqrt(static_cast<double>(n) / sum_gg) : 1.0;
  if (!std::isfinite(albedo_scale) || !(albedo_scale > 0.0)) albedo_scale = 1.0;
  const double lower[3] = {0.0, 0.0, std::log(options.ke_min)};
  const double upper[3] = {options.kd_max * albedo_scale, options.ks_max * albedo_scale, std::log(options.ke_max)};
  const bool free[3] = {kd_free, specular_free, specular_free};
  std::copy(lower, lower + 3, fit->lower);
  std::copy(upper, upper + 3, fit->upper);
  std::copy(free, free + 3, fit->free);

  // Initial point: kd by least squares with ks = 0 (or the fallback kd), ks
  // and ke from the options (ks = 0 when they are not identifiable); ks and
  // ke then from the grid (InitialSpecular).
  double* x = fit->x;
  x[1] = specular_free ? options.initial.ks * albedo_scale : 0.0;
  x[2] = std::log(std::clamp(options.initial.ke, options.ke_min, options.ke_max));
  x[0] = options.initial.kd * albedo_scale;
  if (kd_free && options.initialise_kd_from_data) {
    double s_rg = 0.0, s_gg = 0.0;
    for (size_t i = 0; i < n; ++i) {
      s_rg += data.r[i] * data.diffuse[i];
      s_gg += data.diffuse[i] * data.diffuse[i];
    }
    if (s_gg > 0.0) x[0] = s_rg / s_gg;
  }
}

// The solve from the start SetUpChannel and InitialSpecular left in `fit`.
ChannelOutcome SolveChannel(const PhongFitOptions& options, ChannelFit* fit) {
  ChannelOutcome out;
  PhongChannelData& data = fit->data;
  const size_t n = data.size();
  const double* lower = fit->lower;
  const double* upper = fit->upper;
  const bool* free = fit->free;
  const bool kd_free = free[0], specular_free = free[1];
  const double r_scale = fit->r_scale, to_original = fit->to_original;
  uint32_t flags = fit->flags;
  double* x = fit->x;
  for (int j = 0; j < 3; ++j) x[j] = std::clamp(x[j], lower[j], upper[j]);
  const double x0[3] = {x[0], x[1], x[2]};

  out.summary.start = {x[0] * to_original, x[1] * to_original, std::exp(x[2])};
  // The LM's first pass is at x0 and its last at its result: their costs are
  // the reported ones (the same sums PhongCost takes) unless a robust refit
  // or Powell came between.
  std::optional<double> initial_cost, final_cost;
  const auto solve = [&]() {
    if (options.solver == Solver::kPowell) {
      SolvePowell(data, free, lower, upper, options, x, &out.summary);
    } else {
      const internal::PhongLmSummary lm = SolveLevenbergMarquardt(data, free, lower, upper, options, x, &out.summary);
      if (!initial_cost) initial_cost = lm.initial_cost;
      final_cost = lm.final_cost;
    }
  };
  if (n > 0 && (kd_free || specular_free)) {
    solve();
    if (options.robust.enabled()) {
      RobustRefit(options.robust, solve, x, r_scale, &data, &out.summary);
      final_cost.reset();  // the weighted cost; the plain one is taken below
    }
  }
  if (!initial_cost) initial_cost = PhongCost(data, x0);
  out.summary.initial_cost = *initial_cost * r_scale * r_scale;
  bool finite = true;
  for (int j = 0; j < 3; ++j) finite = finite && std::isfinite(x[j]);
  if (!finite) {  // cannot happen with finite data; never return it
    std::copy(x0, x0 + 3, x);
    flags |= kDidNotConverge;
    final_cost.reset();
  }
  for (int j = 0; j < 3; ++j) {
    x[j] = std::clamp(x[j], lower[j], upper[j]);
    const double margin = kAtBoundFraction * (upper[j] - lower[j]);
    if (free[j] && (x[j] - lower[j] <= margin || upper[j] - x[j] <= margin)) flags |= kAtBound;
  }
  if (!final_cost) final_cost = PhongCost(data, x);
  out.summary.final_cost = *final_cost * r_scale * r_scale;
  out.sum_squares = 2.0 * out.summary.final_cost;
  out.summary.flags |= flags;
  out.params.kd = std::clamp(x[0] * to_original, 0.0, upper[0] * to_original);
  out.params.ks = std::clamp(x[1] * to_original, 0.0, upper[1] * to_original);
  out.params.ke = std::clamp(std::exp(x[2]), options.ke_min, options.ke_max);
  // Fallback values exactly as given (not through the normalisation); the
  // fit is flagged kd_not_identifiable and such a kd is no result.
  if (!kd_free) out.params.kd = std::max(0.0, options.initial.kd);
  if (!specular_free) {
    out.params.ks = 0.0;
    out.params.ke = std::clamp(options.initial.ke, options.ke_min, options.ke_max);
  }
  return out;
}

}  // namespace

const char* RobustLossName(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::kNone:
      return "least-squares";
    case RobustLoss::kHuber:
      return "huber";
    case RobustLoss::kCauchy:
      return "cauchy";
  }
  return "unknown";
}

double RobustOptions::Tuning() const {
  if (tuning > 0.0) return tuning;
  return loss == RobustLoss::kCauchy ? 2.385 : 1.345;
}

double RobustOptions::Weight(double standardised) const {
  const double u = std::fabs(standardised) / Tuning();
  switch (loss) {
    case RobustLoss::kNone:
      return 1.0;
    case RobustLoss::kHuber:
      return u <= 1.0 ? 1.0 : 1.0 / u;
    case RobustLoss::kCauchy:
      return 1.0 / (1.0 + u * u);
  }
  return 1.0;
}

absl::Status RobustOptions::Check() const {
  if (!std::isfinite(tuning) || tuning < 0.0) {
    return absl::InvalidArgumentError(absl::StrCat("robust.tuning: must be >= 0, got ", tuning));
  }
  if (iterations < 0 || iterations > 100) {
    return absl::InvalidArgumentError(absl::StrCat("robust.iterations: must be in [0, 100], got ", iterations));
  }
  return absl::OkStatus();
}

double MadScale(std::vector<double>* x) {
  if (x->empty()) return 0.0;
  const auto median = [](std::vector<double>* v) {
    const size_t mid = v->size() / 2;
    std::nth_element(v->begin(), v->begin() + static_cast<std::ptrdiff_t>(mid), v->end());
    double m = (*v)[mid];
    if (v->size() % 2 == 0)
      m = 0.5 * (m + *std::max_element(v->begin(), v->begin() + static_cast<std::ptrdiff_t>(mid)));
    return m;
  };
  const double m = median(x);
  for (double& v : *x) v = std::fabs(v - m);
  return 1.4826 * median(x);
}

const char* SolverName(Solver solver) {
  switch (solver) {
    case Solver::kLevenbergMarquardt:
      return "levenberg-marquardt";
    case Solver::kPowell:
      return "powell";
  }
  return "unknown";
}

absl::Status PhongFitOptions::Check() const {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (max_iterations <= 0)
    return absl::InvalidArgumentError(absl::StrCat("max_iterations: must be > 0, got ", max_iterations));
  if (!positive(function_tolerance)) {
    return absl::InvalidArgumentError(absl::StrCat("function_tolerance: must be > 0, got ", function_tolerance));
  }
  if (!positive(kd_max)) return absl::InvalidArgumentError(absl::StrCat("kd_max: must be > 0, got ", kd_max));
  if (!positive(ks_max)) return absl::InvalidArgumentError(absl::StrCat("ks_max: must be > 0, got ", ks_max));
  if (!positive(ke_min)) return absl::InvalidArgumentError(absl::StrCat("ke_min: must be > 0, got ", ke_min));
  if (!std::isfinite(ke_max) || !(ke_max > ke_min)) {
    return absl::InvalidArgumentError(absl::StrCat("ke_max: must be > ke_min (", ke_min, "), got ", ke_max));
  }
  if (!std::isfinite(initial.kd) || !std::isfinite(initial.ks) || !std::isfinite(initial.ke)) {
    return absl::InvalidArgumentError(
        absl::StrCat("initial: must be finite, got (", initial.kd, ", ", initial.ks, ", ", initial.ke, ")"));
  }
  if (!std::isfinite(min_cosine) || min_cosine < 0.0) {
    return absl::InvalidArgumentError(absl::StrCat("min_cosine: must be >= 0, got ", min_cosine));
  }
  if (!std::isfinite(highlight_cosine) || highlight_cosine < 0.0 || highlight_cosine >= 1.0) {
    return absl::InvalidArgumentError(absl::StrCat("highlight_cosine: must be in [0, 1), got ", highlight_cosine));
  }
  if (min_highlight_samples < 0) {
    return absl::InvalidArgumentError(absl::StrCat("min_highlight_samples: must be >= 0, got ", min_highlight_samples));
  }
  return robust.Check();
}

absl::StatusOr<PhongFitResult> FitPhong(const SampleSet& set, const std::vector<uint32_t>& indices,
                                        const LightSelection& selection, const PhongFitOptions& options) {
  const LightMask& mask = selection.config;
  const auto start = std::chrono::steady_clock::now();
  if (absl::Status status = options.Check(); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("PhongFitOptions.", status.message()));
  }
  const size_t num_lights = static_cast<size_t>(set.num_lights());
  if (set.light_intensity.size() != num_lights || set.offset.size() != set.size() + 1 ||
      set.offset.back() != set.num_terms() || set.g.size() != set.num_terms() || set.h.size() != set.num_terms() ||
      (!set.falloff.empty() && set.falloff.size() != set.num_terms()) || set.reflectance.size() != set.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("SampleSet: inconsistent sizes (", set.size(), " samples, ", num_lights, " lights, ",
                     set.light_intensity.size(), " intensities, ", set.offset.size(), " offsets, ", set.num_terms(),
                     " terms, ", set.g.size(), " g, ", set.h.size(), " h, ", set.reflectance.size(), " reflectances)"));
  }
  for (size_t j = 0; j < set.num_terms(); ++j) {
    if (set.light[j] >= num_lights) {
      return absl::InvalidArgumentError(
          absl::StrCat("SampleSet: term ", j, " names light ", set.light[j], " of ", num_lights));
    }
  }
  if (mask.End() > num_lights) {
    return absl::InvalidArgumentError(
        absl::StrCat("mask: selects lights beyond the set's ", num_lights, " lights (mask ", mask.ToString(), ")"));
  }
  for (size_t k = 0; k < num_lights; ++k) {
    if (!mask.Test(k)) continue;
    const glm::vec3& intensity = set.light_intensity[k];
    if (!IsFinite(intensity) || intensity.x < 0.0f || intensity.y < 0.0f || intensity.z < 0.0f) {
      return absl::InvalidArgumentError(absl::StrCat("light_intensity[", k, "] (", set.light_names[k],
                                                     "): must be finite and >= 0, got (", intensity.x, ", ",
                                                     intensity.y, ", ", intensity.z, ")"));
    }
  }
  for (size_t j = 0; j < indices.size(); ++j) {
    if (indices[j] >= set.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat("indices[", j, "]: must be < ", set.size(), " (the sample count), got ", indices[j]));
    }
  }

  // The calling thread's arrays from its last fit (FitWorkspace).
  thread_local FitWorkspace workspace;
  const PreparedSamples& prep = workspace.prep;
  Prepare(set, indices, selection, &workspace.prep);
  PhongFitResult result;
  result.solver = options.solver;
  result.samples_used = prep.used.size();
  double sum_squares = 0.0;
  // The channels are independent fits: on their own threads when each is
  // large enough to pay for one (the same results either way).
  ChannelFit* fits = workspace.fits;
  std::vector<ChannelFit*> grid;
  for (int c = 0; c < 3; ++c) {
    fits[c].Reset();
    SetUpChannel(prep, set, c, options, &fits[c]);
    if (fits[c].grid()) grid.push_back(&fits[c]);
  }
  InitialSpecular(options, grid, &workspace.grid);
  ChannelOutcome channels[3];
  if (options.parallel_channels && prep.used.size() >= kParallelChannelSamples &&
      std::thread::hardware_concurrency() > 1) {
    std::thread green([&] { channels[1] = SolveChannel(options, &fits[1]); });
    std::thread blue([&] { channels[2] = SolveChannel(options, &fits[2]); });
    channels[0] = SolveChannel(options, &fits[0]);
    green.join();
    blue.join();
  } else {
    for (int c = 0; c < 3; ++c) channels[c] = SolveChannel(options, &fits[c]);
  }

  for (int c = 0; c < 3; ++c) {
    const ChannelOutcome& channel = channels[c];
    result.params[c] = channel.params;
    result.channels[c] = channel.summary;
    sum_squares += channel.sum_squares;
  }
  result.mse = prep.used.empty() ? 0.0 : sum_squares / (3.0 * static_cast<double>(prep.used.size()));
  workspace.Release();
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

glm::dvec3 EvaluateSampleRgb(const SampleSet& set, size_t i, const LightSelection& mask, const PhongRgb& p) {
  glm::dvec3 f(0.0);
  const bool own = mask.Own(set.frame[i]);
  for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) {
    const int k = set.light[j];
    if (!own && !mask.config.Test(static_cast<size_t>(k))) continue;
    const double g = internal::ClampedCosine(set.g[j]);
    const double h = internal::ClampedHighlight(g, set.h[j]);
    const double a = set.TermFalloff(j);
    const double log_h = internal::LogHighlight(h);
    for (int c = 0; c < 3; ++c) {
      f[c] += set.light_intensity[k][c] *
              (p[c].kd * g + p[c].ks * a * internal::SpecularPowerOfLog(h, log_h, p[c].ke));
    }
  }
  return f;
}

double EvaluateSample(const SampleSet& set, size_t i, const LightSelection& mask, const PhongChannel& p, int c) {
  // Channel c of the three computed alike (each channel's sum is its own).
  return EvaluateSampleRgb(set, i, mask, PhongRgb{p, p, p})[c];
}

}  // namespace mvbrdf::fit
