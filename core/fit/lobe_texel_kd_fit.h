// A cluster's lobe of any model refitted with kd free per texel (issue #15),
// as texel_kd_fit.h does for the thesis's Phong (which keeps its own
// regressors, ln h and exp, so the thesis tables do not move); both solve by
// texel_kd_projection.h.
//
// Every model of core/brdf is linear in kd and in its first parameter p0 once
// its second (the shape: ke, or GGX's roughness) is fixed:
//
//   r_i  ~  kd_t G_i + p0 S1_i + S0_i,
//   G_i  = sum_k I_k W(k) g_k,
//   S1_i = sum_k I_k a_k (S(1; k) - S(0; k)),   S0_i = sum_k I_k a_k S(0; k)
//
// with S(p0; k) the model's specular term and W its diffuse weight at
// (p0, shape), which no model's p0 changes (W = 1 for Phong and Blinn-Phong;
// GGX's 1 - F / F90 = (1 - 1 / phi) (1 - (1 - v.h)^5), ggx.h, its ratio phi
// held at the initial lobe's), and S(0) = 0 for every
// model of core/brdf (S0 kept for one that has a fixed part). So kd_t is
// eliminated in closed form per texel and p0 solves one normal equation
// (variable projection), and the shape is searched on a grid, then by golden
// section; a model with a third parameter (GGX's f90_ratio, held in S and W
// above) has it searched the same way (in ln) at the best shape, and the
// shape again at the best ratio. The refined lobe
// replaces the initial one per channel only when it predicts held-out frames
// (odd from even and back, kd per texel from the other frames) at least as
// well.
#ifndef MVBRDF_CORE_FIT_LOBE_TEXEL_KD_FIT_H_
#define MVBRDF_CORE_FIT_LOBE_TEXEL_KD_FIT_H_

#include <array>

#include "absl/status/statusor.h"
#include "core/fit/lobe_fit.h"
#include "core/samples/sample_set.h"

namespace mvbrdf::fit {

struct LobeTexelKdOptions {
  // Bounds of the shape (ke for Phong and Blinn-Phong, searched in ln ke;
  // GGX's roughness within its own bounds) and of ks (in units of the data's
  // albedo scale, as LobeFitOptions; GGX's F0 as well).
  double ke_min = 1.0;
  double ke_max = 1e4;
  double ks_max = 10.0;
  // GGX's f90_ratio search: the prior of LobeFitOptions::ratio_prior_sigma
  // (the same cost in the data's units: 0.5 mean(r^2) ((ln ratio - ln 25) /
  // sigma)^2 added to the Samples' 0.5 sum of squares). 0: none.
  double ratio_prior_sigma = 1.0;
  int grid_points = 33;
  int golden_iterations = 30;
  // The lobe is kept when the texels' own kd leave less than this fraction
  // of sum S1^2 to inform p0.
  double min_information = 1e-3;
};

struct LobeTexelKdResult {
  std::array<LobeChannel, 3> params;  // refined per channel where `refined`, else the initial
  std::array<bool, 3> refined = {false, false, false};
  std::array<double, 3> held_out_error = {0, 0, 0};
  std::array<double, 3> held_out_error_initial = {0, 0, 0};
  size_t samples_used = 0;
  size_t texels = 0;
  double seconds = 0.0;
};

// `initial` (FitLobe's) starts the search and is kept where the data do not
// inform the lobe. FAILED_PRECONDITION for a half-vector model on Samples
// without the geometry.
absl::StatusOr<LobeTexelKdResult> FitModelLobeWithTexelKd(BrdfModel model, const samples::SampleSet& set,
                                                          const samples::LightSelection& lights,
                                                          const std::array<LobeChannel, 3>& initial,
                                                          const LobeTexelKdOptions& options);

}  // namespace mvbrdf::fit

#endif  // MVBRDF_CORE_FIT_LOBE_TEXEL_KD_FIT_H_
