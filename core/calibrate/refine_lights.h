// Light refinement (issue #14 item 2): after the sweep, the chosen
// configuration's light positions (point lights) or directions (directional
// lights) and relative intensities refined continuously from the triangle
// Samples (the thesis's sweep only picks among candidates), with their
// uncertainty from the solver's Jacobians (a covariance clustered by
// triangle, clustered_covariance.h).
//
// The model is the sweep's (shared/NOTES.md, core/samples/sample_set.h): per
// triangle Sample f_c = sum_k I_kc s_k [kd_c g_k + ks_c a_k h_k^ke] over the
// configuration's lights k that reached the Sample when it was gathered (its
// shadowing is kept), with g_k, h_k and a_k recomputed from the light's
// parameters exactly as core/samples/assemble.cc does, at the triangle's
// centre and face normal in the frame's posed mesh and the camera's viewpoint.
// Unknowns: kd per triangle (RGB) of a subset of triangles, ks (RGB) and ke
// per material group (the triangles nearest to each of the scene's seeds by
// kd; one group without seeds: one shared lobe for cloth, skin and hair moved
// the lights 0.2-0.6 m on clean data), each light's direction and its
// intensity scale s_k. A point light is refined as its direction from the
// subject's centre (the mean of the Samples' positions) at the scene's
// distance: without fall-off that distance is all but unidentifiable (left
// free it drifted 20 % on clean data, within a 2 % better fit), with fall-off
// the intensity scale absorbs most of it. Gauge: kd and ks scale against the
// intensities, so the scales' geometric mean is fixed to 1 (the
// configuration's overall intensity stays the scene's).
// Robust (Cauchy) loss with a scale from the residuals of a least-squares fit
// at the scene's lights; the costs before (lights fixed, everything else
// fitted) and after are of the same loss, so they compare.
//
// Decision (mode auto): the refined lights are used when the robust cost
// drops by at least kMinImprovement and some light moved by at least
// kMinSignificance of its 1-sigma (covariance finite); otherwise the scene's
// lights stay and lights_decision says why. Mode on: used whenever the solve
// and its covariance succeed. Both criteria are ratios: independent of world
// and intensity units.
#ifndef MVBRDF_CORE_CALIBRATE_REFINE_LIGHTS_H_
#define MVBRDF_CORE_CALIBRATE_REFINE_LIGHTS_H_

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "core/samples/sample_set.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/job_options.pb.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::calibrate {

inline constexpr double kMinImprovement = 0.03;  // relative drop of the robust cost
inline constexpr double kMinSignificance = 3.0;  // change / sigma of the most changed light

struct LightRefinementOptions {
  v1::Refinement mode = v1::REFINEMENT_AUTO;  // OFF: RefineLights is not called
  bool inverse_square_falloff = false;        // the scene's lighting.inverse_square_falloff
  size_t max_triangles = 800;                 // triangles (with their kd) in the fit, spread over the mesh
  int max_iterations = 50;
  // Asked between solves; true stops with CANCELLED. May be empty.
  std::function<bool()> cancelled;
};

// Refines the lights named by `configuration` from `triangles` (the triangle
// Samples of pass 1, every scene light; frames with their own lighting are
// left out) and fills report->lights_* (lights_seconds too). OK with
// lights_refined false and the reason when there is nothing to refine (no
// lit Sample, too few triangles, a solve that failed); INVALID_ARGUMENT for a
// configuration naming a light the Samples do not have.
absl::Status RefineLights(const scene::Sequence& sequence, const samples::SampleSet& triangles,
                          const std::vector<std::string>& configuration, const LightRefinementOptions& options,
                          v1::CalibrationReport* report);

// Puts report.lights[].light into sequence->lights (and sequence->scene)
// when report.lights_refined; matched by name. INVALID_ARGUMENT naming the
// light when a row names none of the sequence's.
absl::Status ApplyLightRefinement(const v1::CalibrationReport& report, scene::Sequence* sequence);

// Copies the lights_* fields of `from` into `to` (the cameras' stay).
void CopyLightRefinement(const v1::CalibrationReport& from, v1::CalibrationReport* to);

}  // namespace mvbrdf::calibrate

#endif  // MVBRDF_CORE_CALIBRATE_REFINE_LIGHTS_H_
