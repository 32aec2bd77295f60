// A calibrated camera: OpenCV pinhole intrinsics with distortion, or an
// orthographic (telecentric) camera with square pixels of pixel_size world
// units, and the cam_from_world rigid transform (x right, y down, z forward).
//
//   pinhole:       (u, v) = (fx x/z + cx, fy y/z + cy)   (before distortion)
//   orthographic:  (u, v) = (x / pixel_size + cx, y / pixel_size + cy)
// with (x, y, z) the point in camera coordinates; both see only z > 0. The
// view vector v of the model (surface -> camera, shared/NOTES.md) is
// normalize(C - x) for a pinhole and the constant -z axis of the camera in
// world coordinates for an orthographic camera (ViewDirection).
#ifndef MVBRDF_CORE_SCENE_CAMERA_MODEL_H_
#define MVBRDF_CORE_SCENE_CAMERA_MODEL_H_

#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "mvbrdf/v1/scene.pb.h"

namespace mvbrdf::scene {

enum class Projection { kPinhole, kOrthographic };

struct CameraModel {
  std::string name;
  Projection projection = Projection::kPinhole;
  int width = 0;   // pixels
  int height = 0;  // pixels
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pixels; (0,0) is the centre of the top-left pixel; fx, fy 0 if orthographic
  double pixel_size = 0;                  // orthographic only: world units per (square) pixel
  // OpenCV coefficients k1, k2, p1, p2, k3, k4, k5, k6, zero-padded to 8.
  std::vector<double> distortion = std::vector<double>(8, 0.0);
  glm::dmat3 cam_from_world_rotation{1.0};
  glm::dvec3 cam_from_world_translation{0.0};

  bool has_distortion() const;
  bool orthographic() const { return projection == Projection::kOrthographic; }
  // Camera centre in world coordinates: -R^T t (for an orthographic camera a
  // point on its axis in the plane z = 0).
  glm::dvec3 CenterInWorld() const;
  // The camera's viewpoint as a homogeneous world point: (centre, 1) for a
  // pinhole, (unit direction towards the camera, 0) for an orthographic
  // camera, whose centre lies at infinity. ViewDirection(ViewOrigin(), x) is
  // the model's v; the shaders take this vec4 (u_camera_center).
  glm::dvec4 ViewOrigin() const;
  // The model's unit view vector v at a world point: towards the camera centre
  // (pinhole) or -z_cam in world coordinates (orthographic).
  glm::dvec3 ViewDirection(const glm::dvec3& point_in_world) const;
  glm::dvec3 CamFromWorld(const glm::dvec3& point_in_world) const;
  // Pixels per unit of normalised image coordinates, x and y: (fx, fy), or
  // (1, 1) / pixel_size when orthographic.
  glm::dvec2 PixelScale() const;
  // Normalised image coordinates of a camera-frame point before distortion:
  // (x/z, y/z) for a pinhole, (x, y) for an orthographic camera.
  glm::dvec2 NormalizedCoordinates(const glm::dvec3& point_in_cam) const;
  // Pixel of a world point (with distortion). Points behind the camera
  // (z <= 0) give NaN.
  glm::dvec2 Project(const glm::dvec3& point_in_world) const;
  // The same without distortion (the undistorted pinhole or orthographic pixel).
  glm::dvec2 ProjectUndistorted(const glm::dvec3& point_in_world) const;
  // Normalised image coordinates (x/z, y/z) -> distorted normalised coordinates.
  glm::dvec2 Distort(const glm::dvec2& undistorted) const;
  // Inverse of Distort by fixed-point iteration (as cv::undistortPoints).
  glm::dvec2 Undistort(const glm::dvec2& distorted) const;
};

// The model's unit view vector at `point` for a viewpoint from
// CameraModel::ViewOrigin(): normalize(origin.xyz - origin.w * point).
inline glm::vec3 ViewDirection(const glm::vec4& view_origin, const glm::vec3& point) {
  return glm::normalize(glm::vec3(view_origin) - view_origin.w * point);
}

// The same view (field of view, pose, lens) drawn at width x height pixels:
// the intrinsics scaled by sx = width / camera.width and sy likewise, with
// pixel centres kept: x' = (x + 0.5) s - 0.5, so u = f X/Z + c becomes
// (f s) X/Z + (c + 0.5) s - 0.5 (an orthographic camera's pixel_size / sx;
// its pixels stay square only when sx = sy). `render --size` uses it.
CameraModel Rescaled(const CameraModel& camera, int width, int height);

// Rescaled to `s` times the resolution (s >= 1; the lens distortion,
// in normalised coordinates, is kept): pixel (x, y) of `camera` covers
// pixels [x s, (x + 1) s) x [y s, (y + 1) s) of the result, and their box
// average is what a sensor pixel integrating its area records.
CameraModel Supersampled(const CameraModel& camera, int s);

// Converts a camera message. Assumes the message has been validated
// (ValidateSceneMessage in core/scene/sequence.h); the rotation is used as given.
CameraModel CameraModelFromProto(const v1::Camera& camera);
// The inverse, keeping name, size, model, intrinsics, pixel size and
// extrinsics (not the video).
void CameraModelToProto(const CameraModel& model, v1::Camera* camera);

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_CAMERA_MODEL_H_
