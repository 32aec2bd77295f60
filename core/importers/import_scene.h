// What every calibration importer shares (`mvbrdf import FORMAT ...`): a
// reader turns its format into mvbrdf cameras (name, width, height,
// intrinsics, cam_from_world, model, in proto/mvbrdf/v1/scene.proto's
// conventions); BuildScene turns those into a scene: the camera subset, the
// alignment of the calibration's world with the mesh's, the mesh, videos,
// frames and lights, then the scene's own validation.
#ifndef MVBRDF_CORE_IMPORTERS_IMPORT_SCENE_H_
#define MVBRDF_CORE_IMPORTERS_IMPORT_SCENE_H_

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "mvbrdf/v1/scene.pb.h"

namespace mvbrdf::importers {

// A similarity world_from_calibration:
//   point_in_world = scale * rotation * point_in_calibration + translation.
// It aligns the calibration's world (e.g. COLMAP's arbitrary frame and scale)
// with the mesh's.
struct Similarity {
  double scale = 1.0;
  std::array<double, 9> rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major
  std::array<double, 3> translation{0, 0, 0};
};

// A 4x4 row-major matrix [s R | t; 0 0 0 1] as a Similarity. `field` names it
// in errors. Refused: not 16 finite values, a bottom row other than 0 0 0 1,
// det <= 0 (a mirror) or a 3x3 block that is not a scaled rotation
// (max |A A^T / s^2 - I| > 1e-6, s = cbrt(det A)). Within that, A / s is
// replaced by its nearest rotation (a transform written with 7 digits).
absl::StatusOr<Similarity> SimilarityFromMatrix(const std::vector<double>& m, const std::string& field);
// The same from a JSON file holding an array of 16 numbers.
absl::StatusOr<Similarity> ReadSimilarityFile(const std::filesystem::path& file);

// The camera seeing the world that `world_from_calibration` maps its
// calibration world into. With x_cam = R_c X_c + t_c and X_w = s R X_c + t:
//   X_c = R^T (X_w - t) / s, so x_cam = R_c R^T X_w / s + t_c - R_c R^T t / s;
// scaling camera coordinates by s leaves a pinhole's pixels unchanged, so
//   R' = R_c R^T,  t' = s t_c - R_c R^T t
// (an orthographic camera's pixel_size becomes s * pixel_size).
v1::Camera TransformCamera(const v1::Camera& camera, const Similarity& world_from_calibration);

struct ImportOptions {
  // Directory of the scene file to be written: the mesh, video and
  // segmentation paths are written relative to it.
  std::filesystem::path scene_dir;
  // Mesh file or per-frame pattern ("meshes/mesh_%04d.obj"), as the user gave
  // it (relative to the working directory, or absolute). Required.
  std::string mesh;
  // Video path or image-sequence pattern per camera: "{camera}" is replaced
  // by each camera's name. Required when there is more than one camera
  // (else they would share one video); empty: no video paths.
  std::string video;
  v1::ColorEncoding encoding = v1::SRGB;
  uint32_t bit_depth = 8;
  // scene.frames.
  uint32_t first = 0;
  uint32_t count = 0;
  double fps = 0.0;
  // A LightList JSON ({"lights": [...]}) or a scene JSON whose lights,
  // light_configurations, frame_lighting, lighting, material_seeds,
  // segment_materials and segmentation_path (rebased onto scene_dir) are
  // copied. Empty: the scene has no lights (BuildScene validates everything
  // else; the scene will not validate until lights are added).
  std::string lights_file;
  // Keep only these cameras (in the calibration's order); empty: all.
  std::vector<std::string> cameras;
  // Applied to every camera when set.
  std::optional<Similarity> world_from_calibration;
  // scene.name.
  std::string name;
};

// The scene of `cameras` (as a reader returns them) with `options` applied,
// checked with scene::ValidateSceneMessage (errors name the scene field,
// e.g. "scene.cameras[2].intrinsics.fx: must be > 0, got 0"; INVALID_ARGUMENT
// or NOT_FOUND for option errors, naming the flag's file). No file is
// written, none but lights_file is read.
absl::StatusOr<v1::Scene> BuildScene(std::vector<v1::Camera> cameras, const ImportOptions& options);

// `path` (as given on the command line) relative to `dir`, both made
// absolute first, '/'-separated; absolute when they share no root.
std::string RelativePath(const std::filesystem::path& path, const std::filesystem::path& dir);

}  // namespace mvbrdf::importers

#endif  // MVBRDF_CORE_IMPORTERS_IMPORT_SCENE_H_
