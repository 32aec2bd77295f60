// Camera refinement (issue #14 item 1): each camera's pose (optionally its
// focal length and k1) refined from the video itself before any Sample is
// gathered, so a calibration a pixel off does not decide the light table.
//
// The layer `core/calibrate` sits above rendering and resampling and below the
// pipeline (docs/architecture.md). RefineCameras reads the frames it needs from
// the sequence's videos, solves with Ceres and returns a CalibrationReport
// whose cameras[].camera are the refined cameras; `cameras_refined` says
// whether they should be used (mode on: always; auto: only when cross-camera
// consistency says the calibration is off; `cameras_decision` says why).
#ifndef MVBRDF_CORE_CALIBRATE_REFINE_CAMERAS_H_
#define MVBRDF_CORE_CALIBRATE_REFINE_CAMERAS_H_

#include <functional>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/gl/egl_context.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/job_options.pb.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::calibrate {

struct CameraRefinementOptions {
  v1::Refinement mode = v1::REFINEMENT_AUTO;  // OFF: RefineCameras is not called
  bool focal = false;                         // also fx (= fy scaled alike)
  bool distortion = false;                    // also k1
  // The photometric term in the solve (refine_cameras.cc says what was
  // measured with and without it); false: silhouettes and priors only. The
  // cross-camera consistency is reported either way.
  bool photometric = false;
  int frames = 8;                             // frames used, spread over the sequence
  int threads = 2;
  // Asked between frames; true stops with CANCELLED. May be empty.
  std::function<bool()> cancelled;
};

absl::StatusOr<v1::CalibrationReport> RefineCameras(const scene::Sequence& sequence, gl::EglContext& context,
                                                    const CameraRefinementOptions& options);

// Puts report.cameras[].camera into sequence->cameras (and sequence->scene)
// when report.cameras_refined; matched by name. INVALID_ARGUMENT naming the
// camera when a row names none of the sequence's or changes its size.
absl::Status ApplyCameraRefinement(const v1::CalibrationReport& report, scene::Sequence* sequence);

}  // namespace mvbrdf::calibrate

#endif  // MVBRDF_CORE_CALIBRATE_REFINE_CAMERAS_H_
