// A calibrated camera: OpenCV pinhole intrinsics with distortion and the
// cam_from_world rigid transform (x right, y down, z forward).
#ifndef MVBRDF_CORE_SCENE_CAMERA_MODEL_H_
#define MVBRDF_CORE_SCENE_CAMERA_MODEL_H_

#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "mvbrdf/v1/scene.pb.h"

namespace mvbrdf::scene {

struct CameraModel {
  std::string name;
  int width = 0;   // pixels
  int height = 0;  // pixels
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pixels; (0,0) is the centre of the top-left pixel
  // OpenCV coefficients k1, k2, p1, p2, k3, k4, k5, k6, zero-padded to 8.
  std::vector<double> distortion = std::vector<double>(8, 0.0);
  glm::dmat3 cam_from_world_rotation{1.0};
  glm::dvec3 cam_from_world_translation{0.0};

  bool has_distortion() const;
  // Camera centre in world coordinates: -R^T t.
  glm::dvec3 CenterInWorld() const;
  glm::dvec3 CamFromWorld(const glm::dvec3& point_in_world) const;
  // Pixel of a world point (with distortion). Points behind the camera
  // (z <= 0) give NaN.
  glm::dvec2 Project(const glm::dvec3& point_in_world) const;
  // Normalised image coordinates (x/z, y/z) -> distorted normalised coordinates.
  glm::dvec2 Distort(const glm::dvec2& undistorted) const;
  // Inverse of Distort by fixed-point iteration (as cv::undistortPoints).
  glm::dvec2 Undistort(const glm::dvec2& distorted) const;
};

// Converts a camera message. Assumes the message has been validated
// (ValidateSceneMessage in core/scene/sequence.h); the rotation is used as given.
CameraModel CameraModelFromProto(const v1::Camera& camera);
// The inverse, keeping name, size, intrinsics and extrinsics (not the video).
void CameraModelToProto(const CameraModel& model, v1::Camera* camera);

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_CAMERA_MODEL_H_
