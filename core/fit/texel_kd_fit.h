// A cluster's specular lobe fitted with kd free per texel (issue #14).
//
// The thesis fits one (kd, ks, ke) per cluster and only then kd per texel.
// When the cluster's albedo varies over its texels (a printed cloth), the
// single kd leaves that texture in the residuals and the fit trades it for ks
// and ke: on the clean actor sequence the cloth's ks came out 0.156 off. Here,
// per colour channel,
//
//   r_i  ~  kd_{t(i)} G_i + ks S_i(ke),    S_i(ke) = sum_k I_k a_ik h_ik^ke
//
// with one kd per texel t (the Sample's element) and one ks, ke per cluster.
// For a fixed ke the model is linear: kd_t is eliminated in closed form
// (variable projection), ks solves one normal equation,
//
//   ks = (sum S r - sum_t B_t C_t / A_t) / (sum S^2 - sum_t B_t^2 / A_t),
//   A_t = sum_t G^2,  B_t = sum_t G S,  C_t = sum_t G r,
//
// and ke is searched in log ke over the fitter's bounds (a grid, then a golden
// section around its best point). The refined lobe replaces the initial one
// only when it predicts held-out frames (odd from even and back) at least as
// well, with kd per texel from the other frames. A texel with one Sample, or Samples that see
// its highlight as its diffuse part, explains itself and adds nothing to ks:
// only the variation within texels informs the lobe.
#ifndef MVBRDF_CORE_FIT_TEXEL_KD_FIT_H_
#define MVBRDF_CORE_FIT_TEXEL_KD_FIT_H_

#include <array>
#include <vector>

#include "absl/status/statusor.h"
#include "core/fit/phong_fit.h"
#include "core/samples/sample_set.h"

namespace mvbrdf::fit {

struct TexelKdFitOptions {
  // Bounds of ke and of ks (ks in units of the data's albedo scale
  // A = rms(r) / rms(G), as PhongFitOptions).
  double ke_min = 1.0;
  double ke_max = 1e4;
  double ks_max = 10.0;
  int grid_points = 33;        // over [ln ke_min, ln ke_max]
  int golden_iterations = 30;  // within the best grid cell's neighbours
  // The lobe is kept (the initial parameters returned, `refined` false) when
  // the texels' own kd leave less than this fraction of sum S^2 to inform ks.
  double min_information = 1e-3;
};

struct TexelKdChannel {
  double ks = 0.0;
  double ke = 1.0;
  // The cluster's kd consistent with (ks, ke): sum (r - ks S) G / sum G^2.
  double kd = 0.0;
  double cost = 0.0;          // 0.5 sum of squared residuals with per-texel kd
  double initial_cost = 0.0;  // the same at the initial ks, ke
  // Mean squared error on held-out frames (per texel, kd from the frames of
  // one parity, error on the other, both ways) of the refined lobe and of the
  // initial one; the refined lobe is kept only when it is not worse.
  double held_out_error = 0.0;
  double held_out_error_initial = 0.0;
  bool refined = false;
};

struct TexelKdFitResult {
  std::array<TexelKdChannel, 3> channels;
  size_t samples_used = 0;
  size_t texels = 0;
  double seconds = 0.0;
  // kd from the channels, ks and ke refined (or the initial where not).
  PhongRgb params;
};

// `initial` gives the starting lobe and what is kept where the data cannot
// inform it. Samples with non-finite values are skipped.
absl::StatusOr<TexelKdFitResult> FitLobeWithTexelKd(const samples::SampleSet& set, const samples::LightSelection& mask,
                                                    const PhongRgb& initial, const TexelKdFitOptions& options);

}  // namespace mvbrdf::fit

#endif  // MVBRDF_CORE_FIT_TEXEL_KD_FIT_H_
