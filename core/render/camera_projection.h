// GL matrices of an OpenCV camera (pinhole or orthographic), shared by every
// pass that draws from a camera (the renderer, the resampler's depth maps,
// the id buffer).
#ifndef MVBRDF_CORE_RENDER_CAMERA_PROJECTION_H_
#define MVBRDF_CORE_RENDER_CAMERA_PROJECTION_H_

#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>

#include "core/scene/camera_model.h"

namespace mvbrdf::render {

// OpenCV pinhole (x right, y down, z forward; pixel (0,0) the centre of the
// top-left pixel) of a `width` x `height` grid with principal point (cx, cy),
// as GL clip coordinates from camera coordinates. Pixel (u, v) maps to window
// (u + 0.5, v + 0.5): image row v is window row v, so glReadPixels returns the
// top image row first and no flip is needed. (The image is upside down in
// GL's own y-up sense; no face culling is used, so the mirrored winding is
// harmless.) Depth: near -> -1, far -> +1.
inline glm::dmat4 ClipFromCamera(double fx, double fy, double cx, double cy, int width, int height,
                                 double near_plane, double far_plane) {
  glm::dmat4 p(0.0);  // p[column][row]
  p[0][0] = 2.0 * fx / width;
  p[2][0] = 2.0 * (cx + 0.5) / width - 1.0;
  p[1][1] = 2.0 * fy / height;
  p[2][1] = 2.0 * (cy + 0.5) / height - 1.0;
  p[2][2] = (far_plane + near_plane) / (far_plane - near_plane);
  p[3][2] = -2.0 * far_plane * near_plane / (far_plane - near_plane);
  p[2][3] = 1.0;
  return p;
}

// The orthographic camera u = x / pixel_size + cx, v = y / pixel_size + cy
// (z forward) with the same window and depth conventions: pixel (u, v) maps
// to window (u + 0.5, v + 0.5); camera z = near -> -1, far -> +1 (linear).
inline glm::dmat4 ClipFromOrthographicCamera(double pixel_size, double cx, double cy, int width, int height,
                                             double near_plane, double far_plane) {
  glm::dmat4 p(0.0);  // p[column][row]
  p[0][0] = 2.0 / (pixel_size * width);
  p[3][0] = 2.0 * (cx + 0.5) / width - 1.0;
  p[1][1] = 2.0 / (pixel_size * height);
  p[3][1] = 2.0 * (cy + 0.5) / height - 1.0;
  p[2][2] = 2.0 / (far_plane - near_plane);
  p[3][2] = -(far_plane + near_plane) / (far_plane - near_plane);
  p[3][3] = 1.0;
  return p;
}

// The camera's own projection (pinhole or orthographic), without distortion,
// with its principal point moved to (cx, cy) on a `width` x `height` grid
// (the resampler's depth maps are the image grid shifted).
inline glm::dmat4 ClipFromCamera(const scene::CameraModel& camera, double cx, double cy, int width, int height,
                                 double near_plane, double far_plane) {
  if (camera.orthographic()) {
    return ClipFromOrthographicCamera(camera.pixel_size, cx, cy, width, height, near_plane, far_plane);
  }
  return ClipFromCamera(camera.fx, camera.fy, cx, cy, width, height, near_plane, far_plane);
}

inline glm::dmat4 ClipFromCamera(const scene::CameraModel& camera, double near_plane, double far_plane) {
  return ClipFromCamera(camera, camera.cx, camera.cy, camera.width, camera.height, near_plane, far_plane);
}

// The camera's rigid transform as a 4x4 matrix.
inline glm::dmat4 CamFromWorldMatrix(const scene::CameraModel& camera) {
  glm::dmat4 m(camera.cam_from_world_rotation);
  m[3] = glm::dvec4(camera.cam_from_world_translation, 1.0);
  return m;
}

// Near and far planes of a camera for a scene within the sphere (center,
// radius), world units: no fixed clip planes, so any world scale draws alike.
// The planes enclose the sphere with a margin of 1 % of its radius (plus
// 1e-6 of its distance, for a point-like scene); near is kept as far from 0
// as the scene allows (depth precision), but at least 1e-5 of far when the
// camera is inside the sphere. A scene wholly behind the camera gets an
// arbitrary valid range (nothing is drawn).
struct ClipRange {
  double near_plane = 0.0;
  double far_plane = 0.0;
};

inline ClipRange ClipRangeOf(const scene::CameraModel& camera, const glm::vec3& center, double radius) {
  const double z = camera.CamFromWorld(glm::dvec3(center)).z;
  const double scale = std::max({std::abs(z), radius, 1e-30});
  const double margin = 0.01 * radius + 1e-6 * scale;
  ClipRange range;
  range.far_plane = z + radius + margin;
  if (!(range.far_plane > 0.0)) range.far_plane = scale;
  range.near_plane = std::max(z - radius - margin, range.far_plane * 1e-5);
  return range;
}

}  // namespace mvbrdf::render

#endif  // MVBRDF_CORE_RENDER_CAMERA_PROJECTION_H_
