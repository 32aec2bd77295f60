// PLACEHOLDER (issue #14 item 1 in progress): no refinement yet; the report
// says so. Replaced by the photometric + silhouette refinement.
#include "core/calibrate/refine_cameras.h"

#include "absl/strings/str_cat.h"
#include "core/scene/camera_model.h"

namespace mvbrdf::calibrate {

absl::StatusOr<v1::CalibrationReport> RefineCameras(const scene::Sequence& sequence, gl::EglContext& context,
                                                    const CameraRefinementOptions& options) {
  (void)context;
  v1::CalibrationReport report;
  report.set_cameras_mode(options.mode == v1::REFINEMENT_ON ? "on" : "auto");
  report.set_cameras_refined(false);
  report.set_cameras_decision("camera refinement is not implemented yet");
  for (const scene::CameraModel& camera : sequence.cameras) {
    v1::CameraRefinementRow* row = report.add_cameras();
    row->set_name(camera.name);
    scene::CameraModelToProto(camera, row->mutable_camera());
  }
  return report;
}

absl::Status ApplyCameraRefinement(const v1::CalibrationReport& report, scene::Sequence* sequence) {
  if (!report.cameras_refined()) return absl::OkStatus();
  for (const v1::CameraRefinementRow& row : report.cameras()) {
    bool found = false;
    for (size_t i = 0; i < sequence->cameras.size(); ++i) {
      if (sequence->cameras[i].name != row.name()) continue;
      found = true;
      scene::CameraModel refined = scene::CameraModelFromProto(row.camera());
      if (refined.width != sequence->cameras[i].width || refined.height != sequence->cameras[i].height) {
        return absl::InvalidArgumentError(absl::StrCat("calibration.cameras[", row.name(), "]: size changed"));
      }
      // The video and the rest of the scene's camera stay the scene's.
      v1::Camera* scene_camera = sequence->scene.mutable_cameras(static_cast<int>(i));
      *scene_camera->mutable_intrinsics() = row.camera().intrinsics();
      *scene_camera->mutable_cam_from_world() = row.camera().cam_from_world();
      sequence->cameras[i] = scene::CameraModelFromProto(*scene_camera);
    }
    if (!found) {
      return absl::InvalidArgumentError(
          absl::StrCat("calibration.cameras: \"", row.name(), "\" is no camera of the scene"));
    }
  }
  return absl::OkStatus();
}

}  // namespace mvbrdf::calibrate
