// The parameters camera refinement solves for, per camera, as offsets from
// the scene's calibration (so zero is the calibration):
//   rotation[3]  angle-axis w, R = exp(w) R0 (a rotation of the camera frame);
//   centre[3]    the camera centre's offset in units of the camera's distance
//                to the subject (unit-free: C = C0 + distance * centre);
//   intrinsics[2] focal scale s (fx, fy multiplied by 1 + s) and the offset of k1.
// ProjectWithOffsets is templated for Ceres' Jets; ApplyOffsets gives the
// refined CameraModel.
#ifndef MVBRDF_CORE_CALIBRATE_CAMERA_PARAMETERISATION_H_
#define MVBRDF_CORE_CALIBRATE_CAMERA_PARAMETERISATION_H_

#include <ceres/rotation.h>

#include <array>
#include <glm/glm.hpp>

#include "core/scene/camera_model.h"

namespace mvbrdf::calibrate {

struct CameraOffsets {
  std::array<double, 3> rotation{0, 0, 0};
  std::array<double, 3> centre{0, 0, 0};
  std::array<double, 2> intrinsics{0, 0};
};

// A pinhole camera as plain doubles for the templated projection.
struct PinholeBase {
  double r0[9];  // cam_from_world rotation, row-major
  double c0[3];  // centre in world coordinates
  double distance = 1;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double k[8] = {0, 0, 0, 0, 0, 0, 0, 0};

  static PinholeBase FromCamera(const scene::CameraModel& camera, double distance) {
    PinholeBase b;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) b.r0[3 * r + c] = camera.cam_from_world_rotation[c][r];  // glm is column-major
    }
    const glm::dvec3 centre = camera.CenterInWorld();
    b.c0[0] = centre.x;
    b.c0[1] = centre.y;
    b.c0[2] = centre.z;
    b.distance = distance;
    b.fx = camera.fx;
    b.fy = camera.fy;
    b.cx = camera.cx;
    b.cy = camera.cy;
    for (int i = 0; i < 8; ++i) b.k[i] = camera.distortion[static_cast<size_t>(i)];
    return b;
  }
};

// Pixel of world point x for the camera `base` moved by the offsets. False
// when the point is behind the camera.
template <typename T>
bool ProjectWithOffsets(const PinholeBase& base, const T* rotation, const T* centre, const T* intrinsics,
                        const double* x, T* uv) {
  T d[3];
  for (int i = 0; i < 3; ++i) d[i] = x[i] - (base.c0[i] + base.distance * centre[i]);
  T y[3];
  for (int r = 0; r < 3; ++r) y[r] = base.r0[3 * r] * d[0] + base.r0[3 * r + 1] * d[1] + base.r0[3 * r + 2] * d[2];
  T p[3];
  ceres::AngleAxisRotatePoint(rotation, y, p);
  if (!(p[2] > T(0))) return false;
  const T xn = p[0] / p[2], yn = p[1] / p[2];
  const T k1 = base.k[0] + intrinsics[1];
  const double k2 = base.k[1], p1 = base.k[2], p2 = base.k[3], k3 = base.k[4];
  const double k4 = base.k[5], k5 = base.k[6], k6 = base.k[7];
  const T r2 = xn * xn + yn * yn, r4 = r2 * r2, r6 = r4 * r2;
  const T radial = (T(1) + k1 * r2 + k2 * r4 + k3 * r6) / (T(1) + k4 * r2 + k5 * r4 + k6 * r6);
  const T xd = xn * radial + 2.0 * p1 * xn * yn + p2 * (r2 + 2.0 * xn * xn);
  const T yd = yn * radial + p1 * (r2 + 2.0 * yn * yn) + 2.0 * p2 * xn * yn;
  const T scale = T(1) + intrinsics[0];
  uv[0] = base.fx * scale * xd + base.cx;
  uv[1] = base.fy * scale * yd + base.cy;
  return true;
}

// The scene camera moved by the offsets (name, size and the other
// coefficients kept).
scene::CameraModel ApplyOffsets(const scene::CameraModel& camera, double distance, const CameraOffsets& offsets);

// Angle (degrees) of the rotation between two cameras' orientations.
double RotationAngleDeg(const scene::CameraModel& a, const scene::CameraModel& b);

}  // namespace mvbrdf::calibrate

#endif  // MVBRDF_CORE_CALIBRATE_CAMERA_PARAMETERISATION_H_
