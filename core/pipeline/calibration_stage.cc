#include "core/pipeline/calibration_stage.h"

#include <chrono>

#include "core/base/status_macros.h"

namespace mvbrdf::pipeline {

calibrate::CameraRefinementOptions CameraRefinementOptionsOf(const ReconstructOptions& options) {
  calibrate::CameraRefinementOptions o;
  o.mode = options.refine_cameras;
  o.focal = options.refine_focal;
  o.distortion = options.refine_distortion;
  o.photometric = options.refine_photometric;
  o.frames = options.refine_frames;
  o.threads = options.threads;
  o.cancelled = options.cancelled;
  return o;
}

absl::StatusOr<v1::CalibrationReport> RefineCamerasStage(const scene::Sequence& sequence, gl::EglContext& context,
                                                         const Plan& plan, const ReconstructOptions& options) {
  if (!plan.Has(Stage::kRefineCameras)) {
    v1::CalibrationReport report;
    report.set_cameras_mode(options.refine_cameras == v1::REFINEMENT_OFF  ? "off"
                            : options.refine_cameras == v1::REFINEMENT_ON ? "on"
                                                                          : "auto");
    report.set_cameras_refined(false);
    for (const v1::SkippedStage& s : plan.skipped) {
      if (s.name() == StageName(Stage::kRefineCameras)) report.set_cameras_decision(s.reason());
    }
    return report;
  }
  const auto start = std::chrono::steady_clock::now();
  if (options.progress) options.progress(StageName(Stage::kRefineCameras), 0, 1);
  MVBRDF_ASSIGN_OR_RETURN(v1::CalibrationReport report,
                          calibrate::RefineCameras(sequence, context, CameraRefinementOptionsOf(options)));
  report.set_cameras_seconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  if (options.progress) options.progress(StageName(Stage::kRefineCameras), 1, 1);
  return report;
}

absl::StatusOr<std::optional<scene::Sequence>> CalibratedSequence(const scene::Sequence& sequence,
                                                                  const v1::CalibrationReport& calibration) {
  if (!calibration.cameras_refined()) return std::optional<scene::Sequence>();
  std::optional<scene::Sequence> out = sequence;
  MVBRDF_RETURN_IF_ERROR(calibrate::ApplyCameraRefinement(calibration, &*out));
  return out;
}

}  // namespace mvbrdf::pipeline
