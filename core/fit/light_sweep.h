// The light-configuration sweep (thesis §6.1, Fig. 6.2, Table 6.1): for each
// candidate configuration, fit one Phong BRDF to all triangle Samples, then
// per-triangle kd with its specular part removed; E_a and E_d; pick the best.
//
// Rule (shared/NOTES.md asks for one stated rule), by SweepCriterion: the
// lowest held-out error (issue #14, the default), E_d then E_a breaking ties;
// or the thesis's lowest E_d, E_a breaking ties (relative differences below
// 1e-9 are ties).
//
// The held-out error. E_d separates configurations by a few percent: a
// per-triangle kd absorbs much of a wrong light (a light on a turntable's
// axis adds a nearly constant illumination per triangle), and its one
// average BRDF is fitted with one kd for a textured model (on `spot` its ke
// runs to ~600 where the truth is 12). Instead:
//  1. a joint fit of one specular lobe (ks, ke per channel) with a kd per
//     triangle on every Sample: kd eliminated in closed form (variable
//     projection), ks in closed form for a given ke, ke by a search over
//     [ke_min, ke_max] of PhongFitOptions (a log grid, then refined);
//  2. the frames of the Samples split into kHeldOutFolds contiguous blocks
//     (cameras when the Samples hold one frame); for each block, each
//     triangle's kd fitted on the other blocks with that lobe, and its mean
//     squared error (over channels) on the block's Samples;
//  3. per triangle the mean over its held-out Samples; over triangles the
//     median, so that the few triangles on silhouettes and shadow
//     boundaries, which no configuration models, do not decide.
// A kd fitted on other poses must predict a block's illumination: a wrong
// light's share, absorbed by kd where it was fitted, mispredicts it there.
// Measured (issue #14; margin = the runner-up's error over the best's - 1) on
// the actor 8x30 (E_d: 12 %), with the FitPhong lobe and the mean over
// triangles: 2 frame blocks 18 %, 3 blocks 17 %, 5 blocks 15 %, 10 blocks
// 13 %, one frame out 12 %, interleaved frames 11 %, 2 camera blocks 12 %;
// with the median 52 %, and with the joint lobe too 98 %. On `spot` (E_d
// picks NE,NW,SE,SW,C by 5.9 %) the mean picks it as well (the FitPhong lobe
// and the joint one), the median with the FitPhong lobe picks the truth by
// 2 %, with the joint lobe by 17 %.
#ifndef MVBRDF_CORE_FIT_LIGHT_SWEEP_H_
#define MVBRDF_CORE_FIT_LIGHT_SWEEP_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/fit/diffuse.h"
#include "core/fit/phong_fit.h"
#include "core/samples/sample_set.h"

namespace mvbrdf::fit {

enum class SweepCriterion { kHeldOut, kErrorD };

// Frame blocks of the held-out error (measured: 2 separates best).
constexpr int kHeldOutFolds = 2;

// A held-out margin below this draws the ambiguity warning
// (pipeline::ChooseConfiguration).
constexpr double kAmbiguousHeldOutMargin = 0.05;

struct LightConfiguration {
  std::string name;
  std::vector<std::string> lights;
};

struct SweepRow {
  std::string name;
  std::vector<std::string> lights;
  samples::LightMask mask;
  uint32_t lit_triangles = 0;  // triangles with at least one sample lit (G > 0) by the configuration
  double e_a = 0.0;            // Eq. 6.7
  double e_d = 0.0;            // Eq. 6.8
  double e_held_out = 0.0;     // the held-out error (above); 0 without two frames or cameras
  PhongFitResult fit;          // the average BRDF
  // Robust fits (issue #14): the per-triangle kd's residual scale (per
  // channel) and outlier fraction (DiffuseSolution); 0 for least squares.
  glm::dvec3 triangle_kd_scale{0.0};
  double triangle_kd_outliers = 0.0;
  double seconds = 0.0;
};

struct SweepResult {
  std::vector<SweepRow> rows;  // in the order given
  int best = -1;               // index into rows
};

// `set` holds triangle Samples (element = triangle id), `num_triangles` the
// mesh's triangle count. Configurations naming unknown lights are an error.
// Configurations may be evaluated in parallel (`threads`); results do not
// depend on it. With `max_fit_samples` > 0 the average BRDF is fitted on an
// hashed subsample of about that many Samples (an error-against-
// run-time knob: four parameters per channel need far fewer than the ~1e6
// Samples of a sequence), while E_a, E_d and the per-triangle kd always use
// every Sample. `own_frames` (samples::OwnLightingFrames): frames with their
// own lights, whose Samples count all their terms under every configuration
// (samples::LightSelection). `criterion` picks SweepResult::best.
absl::StatusOr<SweepResult> SweepConfigurations(const samples::SampleSet& set, size_t num_triangles,
                                                const std::vector<LightConfiguration>& configurations,
                                                const PhongFitOptions& fit_options,
                                                const DiffuseOptions& diffuse_options, int threads = 1,
                                                size_t max_fit_samples = 0, const std::vector<uint8_t>& own_frames = {},
                                                SweepCriterion criterion = SweepCriterion::kHeldOut);

// The E_d rule: true when a configuration with errors (e_d, e_a) beats the
// best so far (best_e_d, best_e_a). Rows are compared in the order given, so
// the first of equals wins. The service's `choose` task applies the same rule.
bool PreferConfiguration(double e_d, double e_a, double best_e_d, double best_e_a);

struct ConfigurationErrors {
  double e_a = 0.0, e_d = 0.0, e_held_out = 0.0;
};
// The rule by `criterion`: true when `row` beats `best`.
bool PreferConfiguration(SweepCriterion criterion, const ConfigurationErrors& row, const ConfigurationErrors& best);

}  // namespace mvbrdf::fit

#endif  // MVBRDF_CORE_FIT_LIGHT_SWEEP_H_
