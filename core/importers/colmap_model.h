// Reads a COLMAP sparse model's cameras and poses (cameras.txt + images.txt,
// or cameras.bin + images.bin; https://colmap.github.io/format.html) into
// mvbrdf cameras (proto/mvbrdf/v1/scene.proto conventions).
//
// Conventions converted:
// - Pose: COLMAP stores cam_from_world (world to camera, OpenCV axes: x right,
//   y down, z forward) as a Hamilton quaternion QW QX QY QZ and a translation
//   T; mvbrdf's CamFromWorld is the same transform as a row-major rotation
//   matrix, so only the quaternion is converted (normalised first, as COLMAP
//   does).
// - Pixels: COLMAP puts the centre of the top-left pixel at (0.5, 0.5), mvbrdf
//   at (0, 0): cx = cx_colmap - 0.5, cy = cy_colmap - 0.5 (a silent half-pixel
//   shift otherwise). Focal lengths and distortion are unchanged (both act on
//   normalised coordinates x/z, y/z).
// - Camera models: SIMPLE_PINHOLE (f cx cy), PINHOLE (fx fy cx cy),
//   SIMPLE_RADIAL (f cx cy k), RADIAL (f cx cy k1 k2), OPENCV (fx fy cx cy k1
//   k2 p1 p2), FULL_OPENCV (fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6) become OpenCV
//   distortion vectors of 0, 4, 4, 4, 4 and 8 values (k1 k2 p1 p2[ k3 k4 k5
//   k6]); the fisheye and other models are refused, naming the model and where.
// Each registered image becomes one camera (its pose and its COLMAP camera's
// intrinsics), in increasing IMAGE_ID order.
#ifndef MVBRDF_CORE_IMPORTERS_COLMAP_MODEL_H_
#define MVBRDF_CORE_IMPORTERS_COLMAP_MODEL_H_

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "mvbrdf/v1/scene.pb.h"

namespace mvbrdf::importers {

// How an image NAME such as "cam0/0001.png" becomes a camera name.
enum class ColmapCameraName {
  kStem,       // the file name without its extension: "0001"
  kDirectory,  // the directory holding the image: "cam0"
};

struct ColmapOptions {
  ColmapCameraName camera_name = ColmapCameraName::kStem;
};

// Reads the model in `model_dir`: the text model when cameras.txt and
// images.txt are there, the binary one when cameras.bin and images.bin are;
// both or neither is an error. Errors name the file and line (text) or the
// byte offset and image (binary). Two images giving the same camera name are
// refused, naming both.
absl::StatusOr<std::vector<v1::Camera>> ReadColmapModel(const std::filesystem::path& model_dir,
                                                        const ColmapOptions& options = {});

// The row-major rotation of the Hamilton quaternion (w, x, y, z), normalised
// first; INVALID_ARGUMENT for a zero or non-finite quaternion.
absl::StatusOr<std::array<double, 9>> RotationFromQuaternion(double w, double x, double y, double z);

// One COLMAP camera's intrinsics in mvbrdf's convention (the pixel shift
// applied, the distortion vector as above). `model` is COLMAP's model name;
// `where` prefixes errors (e.g. "model/cameras.txt:4").
absl::StatusOr<v1::Intrinsics> IntrinsicsFromColmap(const std::string& model, const std::vector<double>& params,
                                                    const std::string& where);

}  // namespace mvbrdf::importers

#endif  // MVBRDF_CORE_IMPORTERS_COLMAP_MODEL_H_
