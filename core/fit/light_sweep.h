// The light-configuration sweep (thesis §6.1, Fig. 6.2, Table 6.1): for each
// candidate configuration, fit one Phong BRDF to all triangle Samples, then
// per-triangle kd with its specular part removed; E_a and E_d; pick the best.
//
// Rule (shared/NOTES.md asks for one stated rule): the lowest E_d; E_a breaks
// ties (relative difference below 1e-9).
#ifndef MVBRDF_CORE_FIT_LIGHT_SWEEP_H_
#define MVBRDF_CORE_FIT_LIGHT_SWEEP_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/fit/diffuse.h"
#include "core/fit/phong_fit.h"
#include "core/samples/sample_set.h"

namespace mvbrdf::fit {

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
// (samples::LightSelection).
absl::StatusOr<SweepResult> SweepConfigurations(const samples::SampleSet& set, size_t num_triangles,
                                                const std::vector<LightConfiguration>& configurations,
                                                const PhongFitOptions& fit_options,
                                                const DiffuseOptions& diffuse_options, int threads = 1,
                                                size_t max_fit_samples = 0,
                                                const std::vector<uint8_t>& own_frames = {});

// The rule: true when a configuration with errors (e_d, e_a) beats the best
// so far (best_e_d, best_e_a). Rows are compared in the order given, so the
// first of equals wins. The service's `choose` task applies the same rule.
bool PreferConfiguration(double e_d, double e_a, double best_e_d, double best_e_a);

}  // namespace mvbrdf::fit

#endif  // MVBRDF_CORE_FIT_LIGHT_SWEEP_H_
