#include "core/calibrate/camera_parameterisation.h"

#include <algorithm>
#include <cmath>

namespace mvbrdf::calibrate {

scene::CameraModel ApplyOffsets(const scene::CameraModel& camera, double distance, const CameraOffsets& offsets) {
  scene::CameraModel out = camera;
  double m[9];
  ceres::AngleAxisToRotationMatrix(offsets.rotation.data(), m);  // column-major
  glm::dmat3 delta;
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r < 3; ++r) delta[c][r] = m[3 * c + r];
  }
  out.cam_from_world_rotation = delta * camera.cam_from_world_rotation;
  const glm::dvec3 centre =
      camera.CenterInWorld() + distance * glm::dvec3(offsets.centre[0], offsets.centre[1], offsets.centre[2]);
  out.cam_from_world_translation = -(out.cam_from_world_rotation * centre);
  out.fx = camera.fx * (1.0 + offsets.intrinsics[0]);
  out.fy = camera.fy * (1.0 + offsets.intrinsics[0]);
  out.distortion[0] = camera.distortion[0] + offsets.intrinsics[1];
  return out;
}

double RotationAngleDeg(const scene::CameraModel& a, const scene::CameraModel& b) {
  const glm::dmat3 r = a.cam_from_world_rotation * glm::transpose(b.cam_from_world_rotation);
  const double c = std::clamp((r[0][0] + r[1][1] + r[2][2] - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c) * 180.0 / 3.14159265358979323846;
}

}  // namespace mvbrdf::calibrate
