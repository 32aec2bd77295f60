// Fitting any BRDF model of core/brdf to one cluster's Samples (issue #15
// item 3), one colour channel at a time: kd and the model's parameters (two;
// GGX three).
//
//   r_i  ~  sum_{k in mask} I_kc ( kd W(p; G_ik) g_ik + a_k S(p; G_ik) )
//
// with G_ik the geometry of sample i and light k (core/brdf/geometry.h: n.l =
// g_ik / a_k, n.v, n.h, v.h from the Samples' half-vector geometry, R(l).v =
// h_ik), S the model's specular radiance per unit intensity (brdf::Phong,
// BlinnPhong, Ggx ::Specular), W its diffuse weight (1, or GGX's 1 - F / F90:
// no parameter's), g_ik and a_k as in SampleSet (visibility and fall-off
// folded into g).
//
// Units: kd and every model's lobe scale (Phong's and Blinn-Phong's ks, GGX's
// F0: ggx.h's F scales with it) are solved in units of the data's albedo
// scale A = rms(r) / rms(G) (as FitPhong), so that scaling every I_k by s
// scales them by exactly 1/s, and the shape (ke, roughness) not at all.
//
// The solve: a grid over the model's shape parameter (ke or roughness; GGX's
// f90_ratio at a dielectric's 25) with kd and the lobe's scale by linear least
// squares starts Ceres' Levenberg-Marquardt with the models' analytic
// Jacobians (ke as ln ke), every parameter free.
#ifndef MVBRDF_CORE_FIT_LOBE_FIT_H_
#define MVBRDF_CORE_FIT_LOBE_FIT_H_

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/brdf/geometry.h"
#include "core/brdf/model.h"
#include "core/fit/phong_fit.h"
#include "core/samples/assemble.h"
#include "core/samples/sample_set.h"

namespace mvbrdf::fit {

using BrdfModel = brdf::Model;

struct LobeChannel {
  double kd = 0.0;
  // The model's parameters, in brdf::ParameterNames' order (the third only
  // for a model with three).
  brdf::ParameterVector p = {0.0, 1.0, 0.0};
};

struct LobeFitOptions {
  int max_iterations = 100;
  double function_tolerance = 1e-12;
  // In units of the albedo scale A (see above).
  double kd_max = 10.0;
  double ks_max = 10.0;
  // GGX's f90_ratio: a prior towards a dielectric's 25 of this standard
  // deviation in ln(F90 / F0), one residual beside the Samples' (each in
  // units of the data's rms), so that data that barely inform the ratio (no
  // grazing observations: F0 and the ratio then trade along a valley) keep
  // it near 25, and data that do move it (a metal to 1). 0: no prior.
  double ratio_prior_sigma = 1.0;
  // ke, Phong (Blinn-Phong's upper bound is 4 ke_max: a half-vector exponent
  // is ~4x the mirror one of the same lobe).
  double ke_min = 1.0;
  double ke_max = 1e4;
  // ks and the shape are reported not identifiable (kKsKeNotIdentifiable)
  // when fewer than this many samples have a lobe cosine (R(l).v, or n.h)
  // above `highlight_cosine`.
  int min_highlight_samples = 10;
  double highlight_cosine = 0.9;
  absl::Status Check() const;
};

struct LobeFitResult {
  BrdfModel model = BrdfModel::kPhong;
  std::array<LobeChannel, 3> params;
  std::array<ChannelFitSummary, 3> channels;  // costs in the data's units: 0.5 sum r^2
  size_t samples_used = 0;
  double seconds = 0.0;
  double mse = 0.0;  // over samples and channels
  uint32_t flags() const { return channels[0].flags | channels[1].flags | channels[2].flags; }
};

// Fits `model` to the samples `indices` of `set` (all when empty) for the
// lights of `lights`. FAILED_PRECONDITION when the model needs the half-vector
// geometry and the set has none; samples with non-finite values are skipped
// (flagged kNonFiniteInput). Never returns non-finite parameters.
absl::StatusOr<LobeFitResult> FitLobe(BrdfModel model, const samples::SampleSet& set,
                                      const std::vector<uint32_t>& indices, const samples::LightSelection& lights,
                                      const LobeFitOptions& options);

// The geometry of term j of sample i (n.l = g / a; the half-vector cosines
// when the set has them, else 0).
brdf::Geometry TermGeometry(const samples::SampleSet& set, size_t i, size_t j);
// The model's specular term and diffuse weight (core/brdf) at `p`.
double ModelSpecular(BrdfModel model, const brdf::ParameterVector& p, const brdf::Geometry& geometry);
double ModelDiffuseWeight(BrdfModel model, const brdf::ParameterVector& p, const brdf::Geometry& geometry);

// One observation's terms under a fitted model, per channel: the specular
// radiance S = sum_k I_k a_k S(p; G_k) and the diffuse illumination
// G = sum_k I_k W(p; G_k) g_k of the lights in `mask`, so that r ~ kd G + S
// (for Phong G is the thesis's sum I_k g_k). The terms must carry the
// half-vector geometry (the assemblers' LightTerms always do).
void LobeTerms(BrdfModel model, const std::array<LobeChannel, 3>& p, const samples::LightTerms& terms,
               const std::vector<glm::vec3>& intensity, const samples::LightMask& mask, glm::vec3* specular,
               glm::vec3* illumination);

// The model's value for sample i, channel c (the fit's f_i).
double EvaluateLobe(BrdfModel model, const samples::SampleSet& set, size_t i, const samples::LightSelection& lights,
                    const LobeChannel& p, int c);

}  // namespace mvbrdf::fit

#endif  // MVBRDF_CORE_FIT_LOBE_FIT_H_
