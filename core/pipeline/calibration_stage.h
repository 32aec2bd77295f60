// The plan's `refine_cameras` stage (issue #14 item 1) as the pipeline runs
// it: calibrate::RefineCameras before pass 1, its cameras put into a copy of
// the sequence, so that pass 1, the sweep, pass 2, Table 7.1 and the report's
// renderings all use the cameras as refined. RunReconstruction runs it; so
// does the service's gather task, which returns the report in
// GatherResult.calibration for every later task of the job to apply.
#ifndef MVBRDF_CORE_PIPELINE_CALIBRATION_STAGE_H_
#define MVBRDF_CORE_PIPELINE_CALIBRATION_STAGE_H_

#include <optional>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/calibrate/refine_cameras.h"
#include "core/gl/egl_context.h"
#include "core/pipeline/plan.h"
#include "core/pipeline/reconstruct_stage.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::pipeline {

// calibrate::CameraRefinementOptions from options.refine_* (and threads,
// cancelled).
calibrate::CameraRefinementOptions CameraRefinementOptionsOf(const ReconstructOptions& options);

// The cameras part of RunReport.calibration: when the plan has
// refine_cameras, calibrate::RefineCameras (cameras_seconds measured here;
// progress "refine_cameras" 0 and 1 of 1); when it skips it, cameras_mode "off" or
// "auto" and the plan's reason as cameras_decision, no rows, not refined.
absl::StatusOr<v1::CalibrationReport> RefineCamerasStage(const scene::Sequence& sequence, gl::EglContext& context,
                                                         const Plan& plan, const ReconstructOptions& options);

// A copy of `sequence` with the calibration's cameras when cameras_refined
// (calibrate::ApplyCameraRefinement), else nullopt: the scene's are used.
absl::StatusOr<std::optional<scene::Sequence>> CalibratedSequence(const scene::Sequence& sequence,
                                                                  const v1::CalibrationReport& calibration);

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_CALIBRATION_STAGE_H_
