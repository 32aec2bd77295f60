// Fitting the extended Phong model (thesis §6.1.2, §6.2.3) to Samples, one
// colour channel at a time (3 parameters each, 9 for RGB):
//
//   r_i  ~  f_i = kd * G_i + ks * sum_{k in mask} I_k h_ik^ke
//   G_i  = sum_{k in mask} I_k g_ik
//
// Parameters are fitted in a well-conditioned form: kd and ks directly with
// bounds [0, max], the exponent as log(ke) in [log ke_min, log ke_max] (ke
// spans 1..1e4 and the residual is smooth in log ke, not in ke). Two solvers:
// Ceres Levenberg-Marquardt with analytic derivatives over blocks of samples,
// and Powell's direction-set method (Numerical Recipes §10.5) on the same
// cost, for the thesis's Table 6.2 comparison.
#ifndef MVBRDF_CORE_FIT_PHONG_FIT_H_
#define MVBRDF_CORE_FIT_PHONG_FIT_H_

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/samples/sample_set.h"

namespace mvbrdf::fit {

struct PhongChannel {
  double kd = 0.0;
  double ks = 0.0;
  double ke = 1.0;
};

// RGB.
using PhongRgb = std::array<PhongChannel, 3>;

enum class Solver { kLevenbergMarquardt, kPowell };
const char* SolverName(Solver solver);

// Robust loss of the fits (issue #14): the residual scale sigma is estimated
// from the data (1.4826 x the median absolute deviation of the residuals of a
// first least-squares pass, so it is in the data's own units and nothing
// assumes a scale), then the fit is repeated by iteratively reweighted least
// squares with the weights of the loss at u = residual / (c sigma):
//   Huber:  w = min(1, 1 / |u|)          (c = 1.345: 95 % efficiency)
//   Cauchy: w = 1 / (1 + u^2)            (c = 2.385: 95 % efficiency)
enum class RobustLoss { kNone, kHuber, kCauchy };
const char* RobustLossName(RobustLoss loss);

// How the loss is applied; shared by FitPhong and the diffuse solves.
struct RobustOptions {
  RobustLoss loss = RobustLoss::kNone;  // kNone: least squares
  double tuning = 0.0;                  // c in units of sigma; 0: the loss's 95 % efficiency constant
  int iterations = 3;                   // reweightings after the least-squares pass
  bool enabled() const { return loss != RobustLoss::kNone; }
  double Tuning() const;
  // The IRLS weight of a residual of `residual / sigma` standard deviations.
  double Weight(double standardised) const;
  absl::Status Check() const;
};

// sigma = 1.4826 median |x - median x| (0 for no values); `x` is reordered.
double MadScale(std::vector<double>* x);

struct PhongFitOptions {
  Solver solver = Solver::kLevenbergMarquardt;
  int max_iterations = 100;
  double function_tolerance = 1e-10;  // relative cost decrease to stop
  // kd_max, ks_max and initial.kd, initial.ks are in units of the data's own
  // albedo scale A = rms(r) / rms(G) (per channel, over the fitted Samples),
  // so that a fit does not depend on the units of intensities and images:
  // scaling every I_k by s scales kd and ks by exactly 1/s.
  double kd_max = 10.0;
  double ks_max = 10.0;
  double ke_min = 1.0;
  double ke_max = 1e4;
  // Initial values (an "average BRDF", thesis §6.1.2; in units of A as
  // above); kd is also initialised from the data by least squares when
  // `initialise_kd_from_data`. Where kd is not identifiable it is
  // initial.kd as given (flagged kd_not_identifiable).
  PhongChannel initial{0.5, 0.1, 10.0};
  bool initialise_kd_from_data = true;
  // Samples with G below this carry no diffuse information and samples
  // whose specular sum is below it none on ks/ke; used for identifiability.
  double min_cosine = 1e-6;
  // ks and ke are reported not identifiable when fewer than this many samples
  // have a highlight cosine above `highlight_cosine`.
  int min_highlight_samples = 10;
  double highlight_cosine = 0.5;
  // Robust loss (issue #14); least squares by default.
  RobustOptions robust;
  // Large fits (>= 1e4 Samples) fit their three channels on threads of their
  // own (the same results either way); false keeps them on the calling thread
  // (scripts/bench-peer compares single-threaded solvers).
  bool parallel_channels = true;

  absl::Status Check() const;
};

// Why a parameter could not be determined from the data; the fitter then
// keeps a fallback value (ks = 0, ke = options.initial.ke, or given ones).
enum FitFlag : uint32_t {
  kFitOk = 0,
  kKsKeNotIdentifiable = 1u << 0,  // no (or too few) samples in a highlight
  kKdNotIdentifiable = 1u << 1,    // no sample with diffuse illumination
  kNoSamples = 1u << 2,
  kNonFiniteInput = 1u << 3,  // some samples were NaN/inf and were skipped
  kDidNotConverge = 1u << 4,
  kAtBound = 1u << 5,  // a parameter ended on its bound
};

struct ChannelFitSummary {
  double initial_cost = 0.0;  // 0.5 * sum of squared residuals
  double final_cost = 0.0;
  // kd, ks, ke the solver started from (after the initial grid over ke),
  // where initial_cost is taken.
  std::array<double, 3> start = {0.0, 0.0, 0.0};
  int iterations = 0;
  uint32_t flags = kFitOk;
  // Robust fits: the residual scale sigma (units of the reflectance) and the
  // fraction of Samples whose final residual is beyond 3 sigma.
  double robust_scale = 0.0;
  double outlier_fraction = 0.0;
};

struct PhongFitResult {
  PhongRgb params;
  std::array<ChannelFitSummary, 3> channels;
  Solver solver = Solver::kLevenbergMarquardt;
  size_t samples_used = 0;
  double seconds = 0.0;
  // Mean squared error over samples and channels (thesis E_a, Eq. 6.7).
  double mse = 0.0;
  uint32_t flags() const { return channels[0].flags | channels[1].flags | channels[2].flags; }
};

// Fits one Phong BRDF to the samples `indices` of `set` (all when empty) for
// the lights in `mask`. Samples with non-finite values are skipped (flagged).
// Never returns non-finite parameters.
absl::StatusOr<PhongFitResult> FitPhong(const samples::SampleSet& set, const std::vector<uint32_t>& indices,
                                        const samples::LightSelection& mask, const PhongFitOptions& options);

// The model value of one sample, channel c.
double EvaluateSample(const samples::SampleSet& set, size_t i, const samples::LightSelection& mask,
                      const PhongChannel& p, int c);

// The three channels' model values of one sample; ln h is taken once per
// term for the three exponents (E_a over millions of Samples in the light
// sweep), each channel's sum as EvaluateSample's alone.
glm::dvec3 EvaluateSampleRgb(const samples::SampleSet& set, size_t i, const samples::LightSelection& mask,
                             const PhongRgb& p);

}  // namespace mvbrdf::fit

#endif  // MVBRDF_CORE_FIT_PHONG_FIT_H_
