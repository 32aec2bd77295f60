// Cameras from an Agisoft Metashape camera export (File > Export > Export
// Cameras, "Agisoft XML"), for `mvbrdf import metashape`.
//
// Read: document/chunk (one chunk)
//   sensors/sensor id=.. type="frame": resolution width/height; calibration
//     (class "adjusted" preferred, else the one given) with f, cx, cy, b1, b2,
//     k1..k4, p1, p2 (absent ones are 0).
//   cameras/camera (also inside cameras/group) with label, sensor_id,
//     component_id and transform: 16 numbers, the row-major 4x4
//     camera-to-chunk matrix, camera axes x right, y down, z forward.
//   components/component id=.. transform (rotation, translation, scale):
//     chunk from component, for a camera with that component_id.
//   chunk transform (rotation, translation, scale): world from chunk.
// world_from_camera = chunk * component * camera; its scale (cube root of the
// determinant) is divided out of the rotation, so the world is the chunk's
// transformed (georeferenced, scaled) frame as Metashape shows it.
//
// Conventions (Metashape Professional manual, appendix "Camera models",
// frame cameras): x = X/Z, y = Y/Z, r^2 = x^2 + y^2,
//   x' = x (1 + k1 r^2 + k2 r^4 + k3 r^6 + k4 r^8) + p1 (r^2 + 2x^2) + 2 p2 x y
//   y' = y (1 + k1 r^2 + k2 r^4 + k3 r^6 + k4 r^8) + p2 (r^2 + 2y^2) + 2 p1 x y
//   u = w/2 + cx + x' (f + b1) + y' b2,   v = h/2 + cy + y' f
// in pixels from the image's top-left corner (the top-left pixel's centre is
// (0.5, 0.5)). So, in mvbrdf's terms (pixel (0,0) = the top-left pixel's
// centre): fx = f + b1, fy = f, cx = w/2 + cx - 0.5, cy = h/2 + cy - 0.5, and
// OpenCV's (k1, k2, p1, p2, k3) = (k1, k2, Metashape p2, Metashape p1, k3):
// Metashape's p1 multiplies the (r^2 + 2x^2) term that OpenCV calls p2.
// Refused, as mvbrdf's model has no such term: b2 (skew) != 0, k4 != 0 (an r^8
// term; OpenCV's k4 is a rational-model denominator, not this), p3, p4 != 0,
// non-frame sensors (fisheye, spherical, ...).
// Cameras without a transform (not aligned) are left out; each one adds a line
// to `warnings`. A camera naming an unknown sensor is an error.
#ifndef MVBRDF_CORE_IMPORTERS_METASHAPE_XML_H_
#define MVBRDF_CORE_IMPORTERS_METASHAPE_XML_H_

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "mvbrdf/v1/scene.pb.h"

namespace mvbrdf::importers {

// The aligned cameras of `xml` in mvbrdf's conventions (name = label, width,
// height, intrinsics, cam_from_world, model PINHOLE; no video), in the file's
// order. INVALID_ARGUMENT "<file>: <element>: ..." for what cannot be read,
// NOT_FOUND when the file does not exist. `warnings` (if not null) gets one
// line per camera left out.
absl::StatusOr<std::vector<v1::Camera>> ReadMetashapeCameras(const std::filesystem::path& xml,
                                                             std::vector<std::string>* warnings = nullptr);

}  // namespace mvbrdf::importers

#endif  // MVBRDF_CORE_IMPORTERS_METASHAPE_XML_H_
