#include "core/importers/import_scene.h"

#include <google/protobuf/struct.pb.h>

#include <cmath>
#include <set>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "core/base/files.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/scene/names.h"
#include "core/scene/sequence.h"

namespace mvbrdf::importers {
namespace {

// How far A A^T / s^2 may be from I: a transform written with ~7 digits.
constexpr double kSimilarityTolerance = 1e-6;

constexpr char kCameraToken[] = "{camera}";

std::array<double, 9> Multiply(const std::array<double, 9>& a, const std::array<double, 9>& b) {
  std::array<double, 9> c{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      for (int k = 0; k < 3; ++k) c[3 * i + j] += a[3 * i + k] * b[3 * k + j];
    }
  }
  return c;
}

std::array<double, 9> Transposed(const std::array<double, 9>& a) {
  return {a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8]};
}

// The rotation nearest to `x` (its polar factor), for a near-rotation such as
// one written with 7 digits: Newton's iteration X <- (X + X^-T) / 2, which
// converges quadratically; X^-T is the cofactor matrix over det X.
std::array<double, 9> NearestRotation(std::array<double, 9> x) {
  for (int iteration = 0; iteration < 8; ++iteration) {
    const std::array<double, 9> cof{x[4] * x[8] - x[5] * x[7], x[5] * x[6] - x[3] * x[8], x[3] * x[7] - x[4] * x[6],
                                    x[2] * x[7] - x[1] * x[8], x[0] * x[8] - x[2] * x[6], x[1] * x[6] - x[0] * x[7],
                                    x[1] * x[5] - x[2] * x[4], x[2] * x[3] - x[0] * x[5], x[0] * x[4] - x[1] * x[3]};
    const double det = x[0] * cof[0] + x[1] * cof[1] + x[2] * cof[2];
    for (int i = 0; i < 9; ++i) x[i] = 0.5 * (x[i] + cof[i] / det);
  }
  return x;
}

absl::Status CopyLights(const std::filesystem::path& file, const std::filesystem::path& scene_dir, v1::Scene* scene) {
  // A LightList ({"lights": [...]}) is also valid scene JSON: one parser for both.
  MVBRDF_ASSIGN_OR_RETURN(const v1::Scene source, scene::ReadScene(file));
  if (source.lights_size() == 0) {
    return absl::InvalidArgumentError(absl::StrCat("--lights ", file.string(), ": has no \"lights\""));
  }
  *scene->mutable_lights() = source.lights();
  *scene->mutable_light_configurations() = source.light_configurations();
  *scene->mutable_frame_lighting() = source.frame_lighting();
  *scene->mutable_lighting() = source.lighting();
  *scene->mutable_material_seeds() = source.material_seeds();
  *scene->mutable_segment_materials() = source.segment_materials();
  if (!source.segmentation_path().empty()) {
    // Relative to the source scene's directory, as every path in a scene.
    const std::filesystem::path from = file.parent_path() / source.segmentation_path();
    scene->set_segmentation_path(RelativePath(from, scene_dir));
  }
  return absl::OkStatus();
}

}  // namespace

std::string RelativePath(const std::filesystem::path& path, const std::filesystem::path& dir) {
  const std::filesystem::path p = std::filesystem::absolute(path).lexically_normal();
  const std::filesystem::path d = std::filesystem::absolute(dir).lexically_normal();
  const std::filesystem::path r = p.lexically_relative(d);
  return (r.empty() ? p : r).generic_string();
}

absl::StatusOr<Similarity> SimilarityFromMatrix(const std::vector<double>& m, const std::string& field) {
  if (m.size() != 16) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": expected 16 numbers (a 4x4 row-major world_from_calibration), got ", m.size()));
  }
  for (size_t i = 0; i < m.size(); ++i) {
    if (!std::isfinite(m[i])) return absl::InvalidArgumentError(absl::StrCat(field, "[", i, "]: not finite"));
  }
  if (m[12] != 0.0 || m[13] != 0.0 || m[14] != 0.0 || m[15] != 1.0) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": the bottom row must be 0 0 0 1, got ", m[12], " ", m[13], " ", m[14], " ", m[15]));
  }
  const std::array<double, 9> a{m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]};
  const double det =
      a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) + a[2] * (a[3] * a[7] - a[4] * a[6]);
  if (!(det > 0.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": not a similarity s R (rotation, scale s > 0): the 3x3 block's determinant is ", det,
                     det < 0 ? " (a mirror)" : ""));
  }
  Similarity s;
  s.scale = std::cbrt(det);
  for (int i = 0; i < 9; ++i) s.rotation[i] = a[i] / s.scale;
  const std::array<double, 9> rrt = Multiply(s.rotation, Transposed(s.rotation));
  double worst = 0.0;
  for (int i = 0; i < 9; ++i) worst = std::max(worst, std::abs(rrt[i] - (i % 4 == 0 ? 1.0 : 0.0)));
  if (worst > kSimilarityTolerance) {
    return absl::InvalidArgumentError(absl::StrCat(
        field, ": not a similarity s R (rotation, scale s > 0): with s = cbrt(det) = ", s.scale,
        ", max |A A^T / s^2 - I| is ", worst, " (at most ", kSimilarityTolerance, "; shear or unequal scales)"));
  }
  // Within the tolerance, the nearest rotation: the cameras' R_c R^T stay
  // orthonormal to rounding (the scene's own check allows 1e-6 too).
  s.rotation = NearestRotation(s.rotation);
  s.translation = {m[3], m[7], m[11]};
  return s;
}

absl::StatusOr<Similarity> ReadSimilarityFile(const std::filesystem::path& file) {
  const std::string field = absl::StrCat("--transform ", file.string());
  MVBRDF_ASSIGN_OR_RETURN(const std::string json, ReadFileToString(file));
  google::protobuf::ListValue list;
  if (absl::Status s = JsonToMessage(json, field, &list); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": expected a JSON array of 16 numbers (4x4 row-major): ", s.message()));
  }
  std::vector<double> m;
  for (int i = 0; i < list.values_size(); ++i) {
    if (!list.values(i).has_number_value()) {
      return absl::InvalidArgumentError(absl::StrCat(field, "[", i, "]: expected a number"));
    }
    m.push_back(list.values(i).number_value());
  }
  return SimilarityFromMatrix(m, field);
}

v1::Camera TransformCamera(const v1::Camera& camera, const Similarity& w) {
  v1::Camera out = camera;
  std::array<double, 9> rc{};
  for (int i = 0; i < 9 && i < camera.cam_from_world().rotation_size(); ++i)
    rc[i] = camera.cam_from_world().rotation(i);
  std::array<double, 3> tc{};
  for (int i = 0; i < 3 && i < camera.cam_from_world().translation_size(); ++i) {
    tc[i] = camera.cam_from_world().translation(i);
  }
  const std::array<double, 9> r = Multiply(rc, Transposed(w.rotation));  // R' = R_c R^T
  v1::CamFromWorld* pose = out.mutable_cam_from_world();
  pose->clear_rotation();
  pose->clear_translation();
  for (double v : r) pose->add_rotation(v);
  for (int i = 0; i < 3; ++i) {  // t' = s t_c - R' t
    pose->add_translation(w.scale * tc[i] - (r[3 * i] * w.translation[0] + r[3 * i + 1] * w.translation[1] +
                                             r[3 * i + 2] * w.translation[2]));
  }
  if (out.pixel_size() != 0.0) out.set_pixel_size(out.pixel_size() * w.scale);
  return out;
}

absl::StatusOr<v1::Scene> BuildScene(std::vector<v1::Camera> cameras, const ImportOptions& options) {
  // The subset, in the calibration's order.
  if (!options.cameras.empty()) {
    std::vector<std::string> names;
    for (const v1::Camera& c : cameras) names.push_back(scene::ShownName(c.name()));
    std::set<std::string> wanted;
    for (const std::string& name : options.cameras) {
      bool found = false;
      for (const v1::Camera& c : cameras) found = found || c.name() == name;
      if (!found) {
        return absl::InvalidArgumentError(absl::StrCat("--cameras: the calibration has no camera \"",
                                                       scene::ShownName(name), "\" (it has ",
                                                       absl::StrJoin(names, ", "), ")"));
      }
      if (!wanted.insert(name).second) {
        return absl::InvalidArgumentError(absl::StrCat("--cameras: \"", scene::ShownName(name), "\" given twice"));
      }
    }
    std::vector<v1::Camera> kept;
    for (v1::Camera& c : cameras) {
      if (wanted.count(c.name()) != 0) kept.push_back(std::move(c));
    }
    cameras = std::move(kept);
  }
  if (cameras.size() > 1 && !options.video.empty() && options.video.find(kCameraToken) == std::string::npos) {
    return absl::InvalidArgumentError(absl::StrCat("--video \"", options.video, "\": must contain ", kCameraToken, " (",
                                                   cameras.size(), " cameras would share one video)"));
  }
  if (options.bit_depth != 8 && options.bit_depth != 16) {
    return absl::InvalidArgumentError(absl::StrCat("--bit-depth: expected 8 or 16, got ", options.bit_depth));
  }

  v1::Scene scene;
  scene.set_name(options.name);
  if (!options.mesh.empty()) scene.mutable_mesh()->set_path(RelativePath(options.mesh, options.scene_dir));
  scene.mutable_frames()->set_first(options.first);
  scene.mutable_frames()->set_count(options.count);
  scene.mutable_frames()->set_fps(options.fps);
  for (v1::Camera& c : cameras) {
    if (options.world_from_calibration.has_value()) c = TransformCamera(c, *options.world_from_calibration);
    if (!options.video.empty()) {
      const std::string video = absl::StrReplaceAll(options.video, {{kCameraToken, c.name()}});
      c.mutable_video()->set_path(RelativePath(video, options.scene_dir));
      c.mutable_video()->set_encoding(options.encoding);
      c.mutable_video()->set_bit_depth(options.bit_depth);
    }
    *scene.add_cameras() = std::move(c);
  }
  if (!options.lights_file.empty()) MVBRDF_RETURN_IF_ERROR(CopyLights(options.lights_file, options.scene_dir, &scene));

  if (scene.lights_size() > 0) {
    MVBRDF_RETURN_IF_ERROR(scene::ValidateSceneMessage(scene));
  } else {
    // Everything but the lights: checked with a stand-in light, not written.
    v1::Scene checked = scene;
    v1::Light* light = checked.add_lights();
    light->set_name("import-check");
    for (double v : {0.0, 0.0, 1.0}) light->add_direction(v);
    MVBRDF_RETURN_IF_ERROR(scene::ValidateSceneMessage(checked));
  }
  return scene;
}

}  // namespace mvbrdf::importers
