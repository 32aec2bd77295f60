// Cameras from OpenCV calibration files (cv::FileStorage: YAML, JSON or
// OpenCV XML), for `mvbrdf import opencv`.
//
// Accepted layout (one camera per map):
//   camera_matrix  3x3 K = [fx 0 cx; 0 fy cy; 0 0 1] (aliases: K, cameraMatrix,
//                  camera_matrix, intrinsics); no skew.
//   distortion_coefficients  OpenCV's (k1, k2, p1, p2[, k3[, k4, k5, k6]]),
//                  0, 4, 5 or 8 values, more only if the extra ones are 0
//                  (aliases: D, dist, distCoeffs, dist_coeffs, distortion).
//                  Optional: none means no distortion.
//   image_width, image_height  (aliases: width/height, imageWidth/imageHeight,
//                  or image_size / imageSize = [width, height]).
//   R (3x3 rotation; aliases rotation, rotation_matrix) or rvec (Rodrigues
//   vector, 3 values; alias rvecs), and T / tvec (3 values; aliases t,
//   translation): world-to-camera, point_in_cam = R * point_in_world + T, as
//   cv::calibrateCamera, cv::solvePnP and cv::stereoCalibrate give them.
//   extrinsics_convention  optional: "world_to_camera" (the default) or
//                  "camera_to_world" for files that store the camera's pose
//                  in the world (R, T then take camera points into the
//                  world and are inverted). Any other value is refused.
//   name           optional camera name (default: the file's stem).
// A matrix is either OpenCV's own (`!!opencv-matrix` rows/cols/dt/data in
// YAML, type_id "opencv-matrix" in JSON, type_id="opencv-matrix" in XML) or
// a plain sequence of numbers (flat, row-major, or a sequence of rows).
// A file holds one camera (its keys at the top level) or a `cameras` sequence
// of such maps, each with a `name`. A directory reads every *.yml, *.yaml,
// *.json and *.xml file in it in name order.
//
// Pixels: OpenCV's pixel (0,0) is the centre of the top-left pixel, as in
// mvbrdf's scenes, so cx, cy are taken as they are (no half-pixel shift).
// Camera axes are OpenCV's (x right, y down, z forward), mvbrdf's too.
#ifndef MVBRDF_CORE_IMPORTERS_OPENCV_CALIBRATION_H_
#define MVBRDF_CORE_IMPORTERS_OPENCV_CALIBRATION_H_

#include <filesystem>
#include <vector>

#include "absl/status/statusor.h"
#include "mvbrdf/v1/scene.pb.h"

namespace mvbrdf::importers {

// The cameras of `file_or_dir` in mvbrdf's conventions (name, width, height,
// intrinsics, cam_from_world, model PINHOLE; no video). INVALID_ARGUMENT
// "<file>: <key>: ..." for a missing or malformed key, NOT_FOUND for a path
// that does not exist.
absl::StatusOr<std::vector<v1::Camera>> ReadOpenCvCalibration(const std::filesystem::path& file_or_dir);

}  // namespace mvbrdf::importers

#endif  // MVBRDF_CORE_IMPORTERS_OPENCV_CALIBRATION_H_
