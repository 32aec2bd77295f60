#include "core/scene/sequence.h"

#include <cmath>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "core/base/files.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/scene/mesh_loader.h"
#include "core/scene/names.h"
#include "core/scene/video_source.h"

namespace mvbrdf::scene {
namespace {

// Rotations are typed in by hand or computed in double: 1e-6 separates a
// rounding error from a matrix that is not a rotation.
constexpr double kRotationTolerance = 1e-6;
// A direction off unit length by less than this is taken as it is (float
// rounding); up to kDirectionRenormaliseTolerance it is renormalised with a note.
constexpr double kUnitLengthTolerance = 1e-6;
// Light intensities and positions are used in float arithmetic (shading,
// squared residuals of the fits): 1e30 squared overflows to inf and came
// out as "mseBrdf": "Infinity". The bounds leave room for any unit system
// (a world in millimetres needs point lights 1e6 times brighter than one in
// metres for the same irradiance) while a squared prediction stays far below
// float's 3e38.
constexpr double kMaxIntensity = 1e12;
constexpr double kMaxLightCoordinate = 1e9;

absl::Status Invalid(absl::string_view field, absl::string_view message) {
  return absl::InvalidArgumentError(absl::StrCat(field, ": ", message));
}

std::string Num(double v) { return absl::StrFormat("%g", v); }

absl::Status CheckPositive(const std::string& field, double v) {
  if (std::isfinite(v) && v > 0.0) return absl::OkStatus();
  if (!std::isfinite(v)) return Invalid(field, absl::StrCat("must be a finite number > 0, got ", Num(v)));
  return Invalid(field, absl::StrCat("must be > 0, got ", Num(v)));
}

absl::Status CheckFinite(const std::string& field, double v) {
  if (std::isfinite(v)) return absl::OkStatus();
  return Invalid(field, absl::StrCat("must be a finite number, got ", Num(v)));
}

absl::Status CheckFiniteValues(const std::string& field, const google::protobuf::RepeatedField<double>& values) {
  for (int i = 0; i < values.size(); ++i) {
    MVBRDF_RETURN_IF_ERROR(CheckFinite(absl::StrCat(field, "[", i, "]"), values.Get(i)));
  }
  return absl::OkStatus();
}

absl::Status CheckCount(const std::string& field, int got, int expected, absl::string_view what) {
  if (got == expected) return absl::OkStatus();
  return Invalid(field, absl::StrCat("expected ", expected, " values (", what, "), got ", got));
}

// Tracks names of one repeated field: non-empty and unique. `list` is the
// repeated field's path ("scene.cameras"); `key` the name field ("name").
class NameRegistry {
 public:
  NameRegistry(std::string list, std::string key) : list_(std::move(list)), key_(std::move(key)) {}

  absl::Status Add(int index, const std::string& name) {
    const std::string field = absl::StrCat(list_, "[", index, "].", key_);
    MVBRDF_RETURN_IF_ERROR(ValidateName(field, name));  // names become file names (names.h)
    const auto [it, inserted] = index_of_.emplace(name, index);
    if (!inserted) {
      return Invalid(
          field, absl::StrCat("duplicate \"", ShownName(name), "\", also ", list_, "[", it->second, "].", key_));
    }
    names_.push_back(name);
    return absl::OkStatus();
  }
  bool Has(const std::string& name) const { return index_of_.count(name) != 0; }
  // The names in the scene's order.
  const std::vector<std::string>& names() const { return names_; }

 private:
  std::string list_, key_;
  std::map<std::string, int> index_of_;
  std::vector<std::string> names_;
};

// A list of references into a registry: each known and listed once.
absl::Status CheckReferences(const std::string& field, const google::protobuf::RepeatedPtrField<std::string>& names,
                             const NameRegistry& known, absl::string_view kind, absl::string_view owner) {
  std::map<std::string, int> seen;
  for (int i = 0; i < names.size(); ++i) {
    const std::string item = absl::StrCat(field, "[", i, "]");
    const std::string& name = names.Get(i);
    if (!known.Has(name)) {
      return Invalid(item, absl::StrCat("unknown ", kind, " \"", ShownName(name), "\"", owner, " (the scene has ",
                                        NameList(known.names()), ")"));
    }
    const auto [it, inserted] = seen.emplace(name, i);
    if (!inserted) {
      return Invalid(item, absl::StrCat("duplicate ", kind, " \"", ShownName(name), "\", also ", field, "[",
                                        it->second, "]", owner));
    }
  }
  return absl::OkStatus();
}

// A path a scene names: relative to the scene's directory and inside it
// ('/'-separated, no ".." component, not absolute), so that a scene (a
// bundle on the server) never makes anyone read a file outside its directory.
absl::Status CheckInsideSceneDir(const std::string& field, const std::string& path) {
  auto bad = [&](absl::string_view why) {
    return Invalid(field, absl::StrCat("must be a relative path inside the scene's directory (", why, "), got \"",
                                       ElideForMessage(path, kMaxShownPathChars), "\""));
  };
  if (path.front() == '/' || std::filesystem::path(path).is_absolute()) return bad("not absolute");
  if (path.find('\\') != std::string::npos) return bad("'/' separates directories, not '\\'");
  for (absl::string_view part : absl::StrSplit(path, '/')) {
    if (part == "..") return bad("no \"..\" component");
  }
  return absl::OkStatus();
}

absl::Status ValidateRotation(const std::string& field, const google::protobuf::RepeatedField<double>& r) {
  MVBRDF_RETURN_IF_ERROR(CheckCount(field, r.size(), 9, "row-major 3x3"));
  MVBRDF_RETURN_IF_ERROR(CheckFiniteValues(field, r));
  double max_error = 0.0;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      double dot = 0.0;
      for (int k = 0; k < 3; ++k) dot += r.Get(i * 3 + k) * r.Get(j * 3 + k);
      max_error = std::max(max_error, std::abs(dot - (i == j ? 1.0 : 0.0)));
    }
  }
  if (max_error > kRotationTolerance) {
    return Invalid(field, absl::StrCat("must be orthonormal, but max |R*R^T - I| is ", Num(max_error), " (tolerance ",
                                       Num(kRotationTolerance), ")"));
  }
  const double det = r.Get(0) * (r.Get(4) * r.Get(8) - r.Get(5) * r.Get(7)) -
                     r.Get(1) * (r.Get(3) * r.Get(8) - r.Get(5) * r.Get(6)) +
                     r.Get(2) * (r.Get(3) * r.Get(7) - r.Get(4) * r.Get(6));
  if (std::abs(det - 1.0) > kRotationTolerance) {
    return Invalid(field, absl::StrCat("determinant must be +1, got ", Num(det), " (a reflection, not a rotation)"));
  }
  return absl::OkStatus();
}

// Video.frame_offset: every selected frame, shifted, is a frame number of
// the video (>= 0, < 2^31 - 1). Whether the video is that long is checked
// when it is probed (ProbeVideo).
absl::Status ValidateFrameOffset(const v1::Camera& camera, const v1::Frames& frames, const std::string& f) {
  const int64_t offset = camera.video().frame_offset();
  if (offset == 0) return absl::OkStatus();
  const bool listed = frames.indices_size() != 0;
  const int64_t first = listed ? frames.indices(0) : frames.first();
  const int64_t last = listed ? frames.indices(frames.indices_size() - 1)
                              : first + (static_cast<int64_t>(std::max<uint32_t>(frames.count(), 1)) - 1) *
                                            std::max<uint32_t>(1, frames.step());
  const std::string name = ShownName(camera.name());
  if (first + offset < 0) {
    return Invalid(f + ".video.frame_offset",
                   absl::StrCat("camera \"", name, "\": frame ", first, " of the sequence would be frame ",
                                first + offset, " of its video, before the video's start (frame_offset ", offset, ")"));
  }
  if (last + offset >= static_cast<int64_t>(INT32_MAX)) {
    return Invalid(f + ".video.frame_offset",
                   absl::StrCat("camera \"", name, "\": frame ", last, " of the sequence would be frame ",
                                last + offset, " of its video, must be < 2^31 - 1 (frame_offset ", offset, ")"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status ValidateCameraGeometry(const v1::Camera& camera, const std::string& f) {
  if (camera.width() == 0 || camera.width() > kMaxImageSide) {
    return Invalid(f + ".width", absl::StrCat("must be in 1..", kMaxImageSide, ", got ", camera.width()));
  }
  if (camera.height() == 0 || camera.height() > kMaxImageSide) {
    return Invalid(f + ".height", absl::StrCat("must be in 1..", kMaxImageSide, ", got ", camera.height()));
  }
  const v1::Intrinsics& in = camera.intrinsics();
  if (!v1::CameraModel_IsValid(camera.model())) {
    return Invalid(f + ".model", absl::StrCat("unknown value ", camera.model(), " (PINHOLE or ORTHOGRAPHIC)"));
  }
  if (camera.model() == v1::ORTHOGRAPHIC) {
    // u = x_cam / pixel_size + cx: the focal lengths have no meaning, and a
    // telecentric lens's distortion is not modelled.
    MVBRDF_RETURN_IF_ERROR(CheckPositive(f + ".pixel_size", camera.pixel_size()));
    for (const auto& [name, value] :
         {std::pair<const char*, double>{".intrinsics.fx", in.fx()}, {".intrinsics.fy", in.fy()}}) {
      if (value != 0.0) {
        return Invalid(f + name, absl::StrCat("must be 0 (or absent) for an ORTHOGRAPHIC camera, whose scale is "
                                              "pixel_size; got ",
                                              Num(value)));
      }
    }
    if (in.distortion_size() != 0) {
      return Invalid(f + ".intrinsics.distortion", "must be empty for an ORTHOGRAPHIC camera (no distortion model)");
    }
  } else {
    if (camera.pixel_size() != 0.0) {
      return Invalid(f + ".pixel_size", absl::StrCat("only for an ORTHOGRAPHIC camera (set \"model\": "
                                                     "\"ORTHOGRAPHIC\"); a pinhole camera's scale is fx, fy; got ",
                                                     Num(camera.pixel_size())));
    }
    MVBRDF_RETURN_IF_ERROR(CheckPositive(f + ".intrinsics.fx", in.fx()));
    MVBRDF_RETURN_IF_ERROR(CheckPositive(f + ".intrinsics.fy", in.fy()));
  }
  MVBRDF_RETURN_IF_ERROR(CheckFinite(f + ".intrinsics.cx", in.cx()));
  MVBRDF_RETURN_IF_ERROR(CheckFinite(f + ".intrinsics.cy", in.cy()));
  const int nd = in.distortion_size();
  if (nd != 0 && nd != 4 && nd != 5 && nd != 8) {
    return Invalid(f + ".intrinsics.distortion",
                   absl::StrCat("expected 0, 4, 5 or 8 values (k1, k2, p1, p2[, k3[, k4, k5, k6]]), got ", nd));
  }
  MVBRDF_RETURN_IF_ERROR(CheckFiniteValues(f + ".intrinsics.distortion", in.distortion()));
  MVBRDF_RETURN_IF_ERROR(ValidateRotation(f + ".cam_from_world.rotation", camera.cam_from_world().rotation()));
  const std::string t = f + ".cam_from_world.translation";
  MVBRDF_RETURN_IF_ERROR(CheckCount(t, camera.cam_from_world().translation_size(), 3, "x, y, z"));
  MVBRDF_RETURN_IF_ERROR(CheckFiniteValues(t, camera.cam_from_world().translation()));
  return absl::OkStatus();
}

namespace {

absl::Status ValidateCamera(const v1::Camera& camera, const std::string& f) {
  MVBRDF_RETURN_IF_ERROR(ValidateCameraGeometry(camera, f));
  const v1::Video& video = camera.video();
  if (video.path().empty()) {
    return Invalid(f + ".video.path", "required (a video file or an image pattern such as \"cam0/%04d.png\")");
  }
  MVBRDF_RETURN_IF_ERROR(ValidateFramePattern(video.path(), f + ".video.path"));
  MVBRDF_RETURN_IF_ERROR(CheckInsideSceneDir(f + ".video.path", video.path()));
  if (!v1::ColorEncoding_IsValid(video.encoding())) {
    return Invalid(f + ".video.encoding", absl::StrCat("unknown value ", video.encoding()));
  }
  if (video.bit_depth() != 0 && video.bit_depth() != 8 && video.bit_depth() != 16) {
    return Invalid(f + ".video.bit_depth", absl::StrCat("must be 0, 8 or 16, got ", video.bit_depth()));
  }
  if (!video.mask_path().empty()) {
    MVBRDF_RETURN_IF_ERROR(ValidateFramePattern(video.mask_path(), f + ".video.mask_path"));
    MVBRDF_RETURN_IF_ERROR(CheckInsideSceneDir(f + ".video.mask_path", video.mask_path()));
  }
  if (video.has_saturation_level()) {
    const uint32_t top = video.bit_depth() == 16 ? 65535u : 255u;
    // top + 1: no pixel is saturated.
    if (video.saturation_level() == 0 || video.saturation_level() > top + 1) {
      return Invalid(f + ".video.saturation_level",
                     absl::StrCat("must be in [1, ", top + 1, "] (a stored code value of ", top == 255u ? 8 : 16,
                                  "-bit frames; unset: ", top, "; ", top + 1, ": none saturated), got ",
                                  video.saturation_level()));
    }
  }
  return absl::OkStatus();
}

absl::Status ValidateLight(const v1::Light& light, const std::string& f) {
  const bool point = light.position_size() != 0;
  const bool directional = light.direction_size() != 0;
  if (point == directional) {
    return Invalid(f, absl::StrCat("exactly one of position (point light) and direction (directional light) is "
                                   "required, got ",
                                   point ? "both" : "neither"));
  }
  if (point) {
    MVBRDF_RETURN_IF_ERROR(CheckCount(f + ".position", light.position_size(), 3, "x, y, z"));
    MVBRDF_RETURN_IF_ERROR(CheckFiniteValues(f + ".position", light.position()));
    for (int i = 0; i < 3; ++i) {
      if (std::abs(light.position(i)) > kMaxLightCoordinate) {
        return Invalid(absl::StrCat(f, ".position[", i, "]"),
                       absl::StrCat("must be within +-", Num(kMaxLightCoordinate),
                                    " (world units; use a direction "
                                    "for a distant light), got ",
                                    Num(light.position(i))));
      }
    }
  } else {
    MVBRDF_RETURN_IF_ERROR(CheckCount(f + ".direction", light.direction_size(), 3, "x, y, z"));
    MVBRDF_RETURN_IF_ERROR(CheckFiniteValues(f + ".direction", light.direction()));
    const auto& d = light.direction();
    const double length = std::sqrt(d.Get(0) * d.Get(0) + d.Get(1) * d.Get(1) + d.Get(2) * d.Get(2));
    if (!(std::abs(length - 1.0) <= kDirectionRenormaliseTolerance)) {
      return Invalid(f + ".direction",
                     absl::StrCat("must have unit length (within ", Num(kDirectionRenormaliseTolerance),
                                  ", which is renormalised), got length ", Num(length)));
    }
  }
  if (light.intensity_size() != 0) {
    MVBRDF_RETURN_IF_ERROR(CheckCount(f + ".intensity", light.intensity_size(), 3, "linear R, G, B; or none for 1"));
    for (int i = 0; i < 3; ++i) {
      const double v = light.intensity(i);
      if (!std::isfinite(v) || v < 0.0 || v > kMaxIntensity) {
        return Invalid(absl::StrCat(f, ".intensity[", i, "]"),
                       absl::StrCat("must be a finite number in [0, ", Num(kMaxIntensity),
                                    "] (linear RGB; 1 is the model's unit light), got ", Num(v)));
      }
    }
  }
  return absl::OkStatus();
}

std::string MeshFramePath(const v1::Scene& scene, int absolute_frame) {
  return FormatFramePattern(scene.mesh().path(), absolute_frame);
}

// Protobuf's JSON parse errors come in several lines: the reason, an excerpt
// of the document (itself possibly several lines) and a caret line under the
// offending character. One line is what a CLI prints and a job's error holds:
// the reason, then the excerpt up to the caret with its whitespace collapsed,
// "near ..." as a compiler would say it.
std::string OneLine(absl::string_view message) {
  std::vector<absl::string_view> lines = absl::StrSplit(message, '\n');
  auto collapse = [](absl::string_view text) {
    std::vector<absl::string_view> words = absl::StrSplit(text, absl::ByAnyChar(" \t\r\n"), absl::SkipEmpty());
    return absl::StrJoin(words, " ");
  };
  if (lines.size() >= 3 && absl::StripLeadingAsciiWhitespace(lines.back()) == "^") {
    const size_t caret = lines.back().find('^');
    // The excerpt as it was, newlines included: the caret counts characters of it.
    const size_t begin = lines[1].data() - message.data();
    const size_t end = lines.back().data() - message.data() - 1;  // before the caret line's '\n'
    absl::string_view excerpt = message.substr(begin, end - begin);
    excerpt = excerpt.substr(0, std::min(excerpt.size(), caret + 1));
    if (excerpt.size() > 40) excerpt = excerpt.substr(excerpt.size() - 40);
    return absl::StrCat(lines[0], " near \"", collapse(excerpt), "\"");
  }
  return collapse(message);
}

// Errors name files as the scene does (relative to its directory), not where
// that directory happens to be: on the server and the workers it is an
// unpacked bundle's private path, which a client neither knows nor should
// learn ("meshes/mesh_0002.obj", not "/var/lib/mvbrdf/scenes/<sha>/meshes/...").
absl::Status InSceneTerms(const absl::Status& status, const std::filesystem::path& scene_dir) {
  if (status.ok()) return status;
  std::string prefix = scene_dir.string();
  if (prefix.empty() || prefix == ".") return status;
  if (prefix.back() != '/') prefix += '/';
  return absl::Status(status.code(), absl::StrReplaceAll(status.message(), {{prefix, ""}}));
}

}  // namespace

absl::Status CheckResolvesInsideSceneDir(const std::filesystem::path& scene_dir, const std::string& relative,
                                         const std::string& field) {
  std::error_code ec;
  const std::filesystem::path file = scene_dir / relative;
  if (!std::filesystem::exists(file, ec)) return absl::OkStatus();
  const std::filesystem::path real_dir = std::filesystem::canonical(scene_dir, ec);
  if (ec) return absl::InternalError(absl::StrCat(field, ": cannot resolve ", scene_dir.string(), ": ", ec.message()));
  const std::filesystem::path real_file = std::filesystem::canonical(file, ec);
  if (ec) return absl::InternalError(absl::StrCat(field, ": cannot resolve ", file.string(), ": ", ec.message()));
  const std::filesystem::path inside = real_file.lexically_relative(real_dir);
  if (inside.empty() || *inside.begin() == "..") {
    return absl::InvalidArgumentError(absl::StrCat(field, ": \"", relative, "\" resolves to ", real_file.string(),
                                                   ", outside the scene's folder (a bundle is self-contained)"));
  }
  return absl::OkStatus();
}

namespace {

// Every file the scene names (as core/bundle packs them, in that order)
// resolves inside the scene's folder: what submit and run would refuse is
// refused by validate and run --direct too, with the same message.
absl::Status CheckFilesResolveInside(const Sequence& seq) {
  const v1::Scene& scene = seq.scene;
  auto each_frame = [&](const std::string& path, const std::string& field,
                        const FrameSelection& selection) -> absl::Status {
    if (!IsFramePattern(path)) return CheckResolvesInsideSceneDir(seq.scene_dir, path, field);
    for (int t = 0; t < seq.num_frames; ++t) {
      const int absolute = selection.Absolute(t);
      MVBRDF_RETURN_IF_ERROR(CheckResolvesInsideSceneDir(seq.scene_dir, FormatFramePattern(path, absolute),
                                                         absl::StrCat(field, " (frame ", absolute, ")")));
    }
    return absl::OkStatus();
  };
  MVBRDF_RETURN_IF_ERROR(each_frame(scene.mesh().path(), "scene.mesh.path", seq.frames));
  for (int i = 0; i < scene.cameras_size(); ++i) {
    const v1::Video& video = scene.cameras(i).video();
    const FrameSelection camera_frames = CameraFrames(seq.frames, video);
    MVBRDF_RETURN_IF_ERROR(each_frame(video.path(), absl::StrCat("scene.cameras[", i, "].video.path"), camera_frames));
    if (!video.mask_path().empty()) {
      MVBRDF_RETURN_IF_ERROR(
          each_frame(video.mask_path(), absl::StrCat("scene.cameras[", i, "].video.mask_path"), camera_frames));
    }
  }
  if (!scene.segmentation_path().empty()) {
    MVBRDF_RETURN_IF_ERROR(
        CheckResolvesInsideSceneDir(seq.scene_dir, scene.segmentation_path(), "scene.segmentation_path"));
  }
  return absl::OkStatus();
}

}  // namespace

FrameSelection SelectedFrames(const v1::Frames& frames) {
  FrameSelection s;
  s.first = static_cast<int>(frames.first());
  s.step = static_cast<int>(std::max<uint32_t>(1, frames.step()));
  for (uint32_t i : frames.indices()) s.indices.push_back(static_cast<int>(i));
  return s;
}

int NumSelectedFrames(const v1::Frames& frames) {
  return frames.indices_size() != 0 ? frames.indices_size() : static_cast<int>(frames.count());
}

absl::StatusOr<v1::Scene> ReadScene(const std::filesystem::path& scene_file) {
  absl::StatusOr<v1::Scene> scene = ReadJsonFileAs<v1::Scene>(scene_file);
  if (scene.ok()) return scene;
  return absl::Status(scene.status().code(), OneLine(scene.status().message()));
}

absl::Status ValidateSceneMessage(const v1::Scene& scene) {
  // Mesh and frames.
  if (scene.mesh().path().empty()) {
    return Invalid("scene.mesh.path", "required (a mesh file or a per-frame pattern such as \"mesh_%04d.obj\")");
  }
  MVBRDF_RETURN_IF_ERROR(ValidateFramePattern(scene.mesh().path(), "scene.mesh.path"));
  MVBRDF_RETURN_IF_ERROR(CheckInsideSceneDir("scene.mesh.path", scene.mesh().path()));
  const v1::Frames& frames = scene.frames();
  if (frames.indices_size() != 0) {
    // Explicit absolute indices: count is their number (or 0), no step.
    if (frames.step() > 1) {
      return Invalid("scene.frames.step", absl::StrCat("must be 0 or 1 when frames.indices is given, got ",
                                                       frames.step()));
    }
    if (frames.count() != 0 && frames.count() != static_cast<uint32_t>(frames.indices_size())) {
      return Invalid("scene.frames.count", absl::StrCat("must be 0 or the number of frames.indices (",
                                                        frames.indices_size(), "), got ", frames.count()));
    }
    if (frames.first() != 0) {
      return Invalid("scene.frames.first",
                     absl::StrCat("must be 0 when frames.indices is given (the indices are absolute), got ",
                                  frames.first()));
    }
    for (int i = 0; i < frames.indices_size(); ++i) {
      if (frames.indices(i) > static_cast<uint32_t>(INT32_MAX - 1)) {
        return Invalid(absl::StrCat("scene.frames.indices[", i, "]"),
                       absl::StrCat("must be < 2^31 - 1, got ", frames.indices(i)));
      }
      if (i > 0 && frames.indices(i) <= frames.indices(i - 1)) {
        return Invalid(absl::StrCat("scene.frames.indices[", i, "]"),
                       absl::StrCat("must be strictly increasing, got ", frames.indices(i), " after ",
                                    frames.indices(i - 1)));
      }
    }
  } else {
    if (frames.count() == 0) return Invalid("scene.frames.count", "must be > 0, got 0");
    const uint64_t step = std::max<uint32_t>(1, frames.step());
    if (static_cast<uint64_t>(frames.first()) + (frames.count() - 1) * step >= static_cast<uint64_t>(INT32_MAX)) {
      return Invalid("scene.frames", absl::StrCat("first + (count - 1) * step must be < 2^31 - 1, got ",
                                                  frames.first(), " + ", frames.count() - 1, " * ", step));
    }
  }
  // The plain range (no step, no indices): a frame_lighting entry outside it
  // is an error. With step or indices, entries for frames not selected are
  // ignored (a capture's lighting file lists every photo; the selection picks some).
  const bool plain_frames = frames.indices_size() == 0 && frames.step() <= 1;
  MVBRDF_RETURN_IF_ERROR(CheckPositive("scene.frames.fps", frames.fps()));
  // Durations are count / fps: 1e-320 fps made an infinite one.
  if (frames.fps() < 1e-6 || frames.fps() > 1e6) {
    return Invalid("scene.frames.fps",
                   absl::StrCat("must be in [1e-06, 1e+06] frames per second, got ", Num(frames.fps())));
  }

  // Cameras.
  if (scene.cameras_size() == 0) return Invalid("scene.cameras", "at least one camera is required");
  NameRegistry cameras("scene.cameras", "name");
  for (int i = 0; i < scene.cameras_size(); ++i) {
    MVBRDF_RETURN_IF_ERROR(cameras.Add(i, scene.cameras(i).name()));
    MVBRDF_RETURN_IF_ERROR(ValidateCamera(scene.cameras(i), absl::StrCat("scene.cameras[", i, "]")));
    MVBRDF_RETURN_IF_ERROR(ValidateFrameOffset(scene.cameras(i), frames, absl::StrCat("scene.cameras[", i, "]")));
  }

  // Lights and which of them are on.
  if (scene.lights_size() > kMaxLights) {
    return Invalid("scene.lights", absl::StrCat("at most ", kMaxLights, " lights, got ", scene.lights_size()));
  }
  NameRegistry lights("scene.lights", "name");
  for (int i = 0; i < scene.lights_size(); ++i) {
    MVBRDF_RETURN_IF_ERROR(lights.Add(i, scene.lights(i).name()));
    MVBRDF_RETURN_IF_ERROR(ValidateLight(scene.lights(i), absl::StrCat("scene.lights[", i, "]")));
  }
  // Nothing lit, nothing to reconstruct: said here, not as "no texel was seen
  // lit" after a whole pass over the frames.
  if (scene.lights_size() == 0) {
    return Invalid("scene.lights", "at least one light is required (nothing is lit without one)");
  }
  if (scene.lights_size() > kMaxLights) {
    return Invalid("scene.lights", absl::StrCat("at most ", kMaxLights, " lights (the run's limit), got ",
                                                scene.lights_size()));
  }
  bool some_light = false;
  for (const v1::Light& light : scene.lights()) {
    if (light.intensity_size() == 0) some_light = true;  // (1, 1, 1)
    for (double v : light.intensity()) some_light = some_light || v > 0.0;
  }
  if (!some_light) return Invalid("scene.lights", "every light's intensity is 0 (nothing is lit)");
  NameRegistry configurations("scene.light_configurations", "name");
  for (int i = 0; i < scene.light_configurations_size(); ++i) {
    const v1::LightConfiguration& c = scene.light_configurations(i);
    const std::string f = absl::StrCat("scene.light_configurations[", i, "]");
    MVBRDF_RETURN_IF_ERROR(configurations.Add(i, c.name()));
    if (c.lights_size() == 0) return Invalid(f + ".lights", "at least one light is required");
    MVBRDF_RETURN_IF_ERROR(CheckReferences(f + ".lights", c.lights(), lights, "light",
                                           absl::StrCat(" in configuration \"", ShownName(c.name()), "\"")));
  }
  std::map<uint32_t, int> frame_entry;
  for (int i = 0; i < scene.frame_lighting_size(); ++i) {
    const v1::FrameLighting& fl = scene.frame_lighting(i);
    const std::string f = absl::StrCat("scene.frame_lighting[", i, "]");
    const uint64_t end = static_cast<uint64_t>(frames.first()) + frames.count();
    if (plain_frames && (fl.frame() < frames.first() || fl.frame() >= end)) {
      return Invalid(f + ".frame", absl::StrCat("must be in [", frames.first(), ", ", end,
                                                ") (scene.frames: first, first + count), got ", fl.frame()));
    }
    const auto [it, inserted] = frame_entry.emplace(fl.frame(), i);
    if (!inserted) {
      return Invalid(f + ".frame", absl::StrCat("duplicate frame ", fl.frame(), ", also scene.frame_lighting[",
                                                it->second, "].frame"));
    }
    MVBRDF_RETURN_IF_ERROR(
        CheckReferences(f + ".lights", fl.lights(), lights, "light", absl::StrCat(" in frame ", fl.frame())));
  }

  // Materials.
  NameRegistry seeds("scene.material_seeds", "name");
  for (int i = 0; i < scene.material_seeds_size(); ++i) {
    const v1::MaterialSeed& s = scene.material_seeds(i);
    const std::string f = absl::StrCat("scene.material_seeds[", i, "]");
    MVBRDF_RETURN_IF_ERROR(seeds.Add(i, s.name()));
    // Exactly one of srgb8 (the thesis's seeds) and linear_rgb (an albedo in
    // the data's own units, e.g. for 16-bit linear captures).
    if (s.srgb8_size() > 0 && s.linear_rgb_size() > 0) {
      return Invalid(f, "give one of srgb8 and linear_rgb, not both");
    }
    if (s.linear_rgb_size() > 0) {
      MVBRDF_RETURN_IF_ERROR(CheckCount(f + ".linear_rgb", s.linear_rgb_size(), 3, "linear R, G, B albedo"));
      for (int k = 0; k < 3; ++k) {
        if (!std::isfinite(s.linear_rgb(k)) || s.linear_rgb(k) < 0.0 || s.linear_rgb(k) > 1e12) {
          return Invalid(absl::StrCat(f, ".linear_rgb[", k, "]"),
                         absl::StrCat("must be a finite number in [0, 1e+12], got ", s.linear_rgb(k)));
        }
      }
      continue;
    }
    MVBRDF_RETURN_IF_ERROR(CheckCount(f + ".srgb8", s.srgb8_size(), 3, "8-bit sRGB R, G, B (or linear_rgb)"));
    for (int k = 0; k < 3; ++k) {
      if (s.srgb8(k) > 255) {
        return Invalid(absl::StrCat(f, ".srgb8[", k, "]"), absl::StrCat("must be <= 255, got ", s.srgb8(k)));
      }
    }
  }
  NameRegistry segments("scene.segment_materials", "segment");
  for (int i = 0; i < scene.segment_materials_size(); ++i) {
    const v1::SegmentMaterials& s = scene.segment_materials(i);
    const std::string f = absl::StrCat("scene.segment_materials[", i, "]");
    MVBRDF_RETURN_IF_ERROR(segments.Add(i, s.segment()));
    if (s.materials_size() == 0) return Invalid(f + ".materials", "at least one material seed is required");
    MVBRDF_RETURN_IF_ERROR(CheckReferences(f + ".materials", s.materials(), seeds, "material seed",
                                           absl::StrCat(" in segment \"", ShownName(s.segment()), "\"")));
  }
  if (!scene.segmentation_path().empty()) {
    MVBRDF_RETURN_IF_ERROR(CheckInsideSceneDir("scene.segmentation_path", scene.segmentation_path()));
  }
  if (scene.segment_materials_size() != 0 && scene.segmentation_path().empty()) {
    return Invalid("scene.segment_materials",
                   "given, but scene.segmentation_path is empty (segments need a segmentation file)");
  }
  return absl::OkStatus();
}

namespace {

// One segment name per triangle; every segment of segment_materials must occur.
absl::Status CheckSegmentation(const Sequence& seq) {
  const v1::Scene& scene = seq.scene;
  const std::filesystem::path file = ResolvePath(seq.scene_dir, scene.segmentation_path());
  auto text = ReadFileToString(file);
  if (!text.ok()) {
    if (absl::IsNotFound(text.status())) {
      return absl::NotFoundError(absl::StrCat("scene.segmentation_path: file not found: ", file.string()));
    }
    return text.status();
  }
  std::istringstream in(*text);
  std::string line;
  std::set<std::string> names;
  size_t lines = 0;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    names.insert(line);
    ++lines;
  }
  if (lines != seq.topology.triangles.size()) {
    return Invalid("scene.segmentation_path",
                   absl::StrCat(file.string(), " has ", lines, " lines, expected one per triangle (",
                                seq.topology.triangles.size(), ")"));
  }
  for (int i = 0; i < scene.segment_materials_size(); ++i) {
    const std::string& segment = scene.segment_materials(i).segment();
    if (names.count(segment) == 0) {
      return Invalid(absl::StrCat("scene.segment_materials[", i, "].segment"),
                     absl::StrCat("segment \"", segment, "\" does not occur in ", file.string()));
    }
  }
  return absl::OkStatus();
}

// For a camera with a frame_offset whose video ends early: which frame of
// the sequence is missing, and which video frame that is.
std::string OffsetNote(const Sequence& seq, const v1::Camera& camera, int t) {
  const int offset = camera.video().frame_offset();
  if (offset == 0 || t >= seq.num_frames) return "";
  const int absolute = seq.AbsoluteFrame(t);
  return absl::StrCat("; camera \"", ShownName(camera.name()), "\": frame ", absolute, " of the sequence is frame ",
                      static_cast<int64_t>(absolute) + offset, " of its video, past the video's end (frame_offset ",
                      offset, ")");
}

absl::Status ProbeVideo(const Sequence& seq, int i) {
  const v1::Camera& camera = seq.scene.cameras(i);
  const std::string field = absl::StrCat("scene.cameras[", i, "]");
  const FrameSelection camera_frames = CameraFrames(seq.frames, camera.video());
  const int first = camera_frames.Absolute(0);
  MVBRDF_ASSIGN_OR_RETURN(auto source, VideoSource::Open(camera, seq.scene_dir, seq.frames, seq.num_frames, field));
  MVBRDF_ASSIGN_OR_RETURN(const VideoProbe probe, source->Probe());
  if (probe.width != static_cast<int>(camera.width()) || probe.height != static_cast<int>(camera.height())) {
    return Invalid(field + ".video", absl::StrCat("frames are ", probe.width, "x", probe.height, ", expected ",
                                                  camera.width(), "x", camera.height(), " (camera width x height)"));
  }
  if (probe.frame_count < seq.num_frames) {
    return Invalid(
        field + ".video",
        absl::StrCat("has ", probe.frame_count, " frames from frame ", first, ", the scene needs ", seq.num_frames,
                     seq.frames.step > 1 || !seq.frames.indices.empty() ? " (of those scene.frames selects)" : "",
                     OffsetNote(seq, camera, probe.frame_count)));
  }
  // Every mask file exists (a stat each; read with its frame).
  const std::string& mask = camera.video().mask_path();
  if (!mask.empty()) {
    const int masks = IsFramePattern(mask) ? seq.num_frames : 1;
    for (int t = 0; t < masks; ++t) {
      const std::string shown = IsFramePattern(mask) ? FormatFramePattern(mask, camera_frames.Absolute(t)) : mask;
      if (const std::string why = WhyNotRegularFile(ResolvePath(seq.scene_dir, shown)); !why.empty()) {
        return NotRegularFileError(why, absl::StrCat(field, ".video.mask_path: mask image ", why, ": ",
                                                     ElideForMessage(shown, kMaxShownPathChars)));
      }
    }
  }
  return absl::OkStatus();
}

// Every used frame decodes at the camera's size and bit depth: a video that
// ends early, or one later frame of another size or depth, fails here as it
// would halfway through a run.
absl::Status ReadEveryVideoFrame(const Sequence& seq, int i) {
  const v1::Camera& camera = seq.scene.cameras(i);
  const std::string field = absl::StrCat("scene.cameras[", i, "]");
  MVBRDF_ASSIGN_OR_RETURN(auto source, VideoSource::Open(camera, seq.scene_dir, seq.frames, seq.num_frames, field));
  for (int t = 0; t < seq.num_frames; ++t) MVBRDF_RETURN_IF_ERROR(source->ReadFrame(t).status());
  return absl::OkStatus();
}

// Every later frame's mesh file exists (a stat each; the content is read when
// check_all_frames asks or when the frame is used), so that a bundle without
// one fails when it is submitted, not halfway through a job.
absl::Status CheckMeshFramesExist(const Sequence& seq) {
  for (int t = 1; t < seq.num_frames; ++t) {
    const int absolute = seq.AbsoluteFrame(t);
    const std::filesystem::path file = ResolvePath(seq.scene_dir, MeshFramePath(seq.scene, absolute));
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec)) {
      return absl::NotFoundError(absl::StrCat("scene.mesh.path (frame ", absolute, "): mesh file not found: ",
                                              ElideForMessage(file.string(), kMaxShownPathChars)));
    }
  }
  return absl::OkStatus();
}

// A camera that sees none of the mesh in frame 0 is rejected: it adds no
// sample, and a pose that points away (a transposed rotation, a
// camera_from_world given as world_from_camera) is a calibration error the
// user wants to hear about. Conservative: the camera is rejected only when
// every vertex lies on the outer side of one plane of its viewing frustum
// (behind it, or beyond one image border widened by half the image for lens
// distortion), so that the mesh's convex hull misses the frustum; a close-up
// of a coarse mesh whose vertices are all outside the image still passes.
absl::Status CheckCameraSeesMesh(const Sequence& seq, int i) {
  const CameraModel& camera = seq.cameras[static_cast<size_t>(i)];
  // Frustum in normalised coordinates (x/z, y/z; orthographic: x, y),
  // widened by half the image.
  const glm::dvec2 scale = camera.PixelScale();
  const double x_lo = (-0.5 - 0.5 * camera.width - camera.cx) / scale.x;
  const double x_hi = (1.5 * camera.width - 0.5 - camera.cx) / scale.x;
  const double y_lo = (-0.5 - 0.5 * camera.height - camera.cy) / scale.y;
  const double y_hi = (1.5 * camera.height - 0.5 - camera.cy) / scale.y;
  // Bit k set: some vertex is inside plane k (z > 0, x >= x_lo z, x <= x_hi z, y >= y_lo z, y <= y_hi z;
  // orthographic: the planes x >= x_lo, ... parallel to the axis).
  unsigned inside_some = 0;
  for (const glm::vec3& p : seq.rest_positions) {
    const glm::dvec3 q = camera.CamFromWorld(glm::dvec3(p));
    const double w = camera.orthographic() ? 1.0 : q.z;
    if (q.z > 0.0) inside_some |= 1u;
    if (q.x >= x_lo * w) inside_some |= 2u;
    if (q.x <= x_hi * w) inside_some |= 4u;
    if (q.y >= y_lo * w) inside_some |= 8u;
    if (q.y <= y_hi * w) inside_some |= 16u;
    if (inside_some == 31u) return absl::OkStatus();
  }
  const char* where = (inside_some & 1u) == 0   ? "behind the camera"
                      : (inside_some & 2u) == 0 ? "left of its image"
                      : (inside_some & 4u) == 0 ? "right of its image"
                      : (inside_some & 8u) == 0 ? "above its image"
                                                : "below its image";
  return Invalid(absl::StrCat("scene.cameras[", i, "]"),
                 absl::StrCat("sees none of the mesh in frame 0: all ", seq.rest_positions.size(), " vertices lie ",
                              where, " (check cam_from_world: world to camera, OpenCV axes with z forward",
                              camera.orthographic() && (inside_some & 1u) == 0
                                  ? "; an orthographic camera sees only z_cam > 0: choose translation[2] so that "
                                    "the mesh lies in front of it"
                                  : "",
                              ")"));
}

Light LightFromProto(const v1::Light& l) {
  Light light;
  light.name = l.name();
  light.directional = l.direction_size() == 3;
  if (l.position_size() == 3) light.position = glm::vec3(l.position(0), l.position(1), l.position(2));
  if (light.directional) {
    // Validated within kDirectionRenormaliseTolerance of unit length; used as a unit vector.
    const glm::dvec3 d(l.direction(0), l.direction(1), l.direction(2));
    light.direction = glm::vec3(d / glm::length(d));
  }
  if (l.intensity_size() == 3) light.intensity = glm::vec3(l.intensity(0), l.intensity(1), l.intensity(2));
  return light;
}

}  // namespace

bool Sequence::is_static_mesh() const { return !IsFramePattern(scene.mesh().path()); }

absl::StatusOr<FramePositions> Sequence::LoadFrame(int t) const {
  if (t < 0 || t >= num_frames) {
    return absl::OutOfRangeError(absl::StrCat("frame ", t, " is outside [0, ", num_frames, ")"));
  }
  if (is_static_mesh()) return rest_positions;
  const int absolute = AbsoluteFrame(t);
  const std::filesystem::path file = ResolvePath(scene_dir, MeshFramePath(scene, absolute));
  // The key names what the positions depend on besides the file.
  const std::string key = absl::StrCat(file.string(), scene.mesh().flip_winding() ? " flipped " : " ",
                                       topology.num_file_vertices, " ", topology.file_triangles.size());
  if (frame_cache != nullptr) {
    if (std::optional<FramePositions> kept = frame_cache->Find(key)) return *std::move(kept);
  }
  absl::StatusOr<FramePositions> positions = LoadFramePositions(
      file, topology, absl::StrCat("scene.mesh.path (frame ", absolute, ")"), scene.mesh().flip_winding());
  if (!positions.ok()) return InSceneTerms(positions.status(), scene_dir);
  if (frame_cache != nullptr) frame_cache->Keep(key, *positions);
  return positions;
}

int Sequence::FindLight(const std::string& name) const {
  for (size_t i = 0; i < lights.size(); ++i) {
    if (lights[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

const v1::FrameLighting* Sequence::FrameLightingOf(int t) const {
  if (t < 0 || t >= num_frames) return nullptr;
  const uint64_t frame = static_cast<uint64_t>(AbsoluteFrame(t));
  for (const v1::FrameLighting& fl : scene.frame_lighting()) {
    if (fl.frame() == frame) return &fl;
  }
  return nullptr;
}

bool Sequence::every_frame_lit_own() const {
  // Validation refuses duplicate frames; entries for unselected frames do not count.
  if (num_frames <= 0 || scene.frame_lighting_size() < num_frames) return false;
  for (int t = 0; t < num_frames; ++t) {
    if (FrameLightingOf(t) == nullptr) return false;
  }
  return true;
}

namespace {

absl::StatusOr<Sequence> LoadAndCheck(const std::filesystem::path& scene_file, const LoadOptions& options) {
  Sequence seq;
  seq.scene_file = scene_file;
  seq.scene_dir = scene_file.has_parent_path() ? scene_file.parent_path() : std::filesystem::path(".");
  MVBRDF_ASSIGN_OR_RETURN(seq.scene, ReadScene(scene_file));
  MVBRDF_RETURN_IF_ERROR(ValidateSceneMessage(seq.scene));
  const v1::Scene& scene = seq.scene;
  seq.frames = SelectedFrames(scene.frames());
  seq.num_frames = NumSelectedFrames(scene.frames());
  const int first = seq.AbsoluteFrame(0);
  MVBRDF_RETURN_IF_ERROR(CheckFilesResolveInside(seq));

  const std::string mesh_field =
      seq.is_static_mesh() ? std::string("scene.mesh.path") : absl::StrCat("scene.mesh.path (frame ", first, ")");
  MVBRDF_ASSIGN_OR_RETURN(LoadedMesh mesh,
                          LoadMesh(ResolvePath(seq.scene_dir, MeshFramePath(scene, first)), mesh_field,
                                   scene.mesh().flip_winding()));
  seq.topology = std::move(mesh.topology);
  seq.rest_positions = std::move(mesh.positions);
  if (!seq.topology.triangles.empty() && seq.topology.zero_area_triangles.size() == seq.topology.triangles.size()) {
    // Zero relative to the mesh's size: one vertex at 1e30 makes every other
    // triangle a speck, so the extent is named too.
    glm::vec3 lo(0.0f), hi(0.0f);
    if (!seq.rest_positions.empty()) lo = hi = seq.rest_positions[0];
    for (const glm::vec3& p : seq.rest_positions) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    return Invalid(mesh_field,
                   absl::StrCat("all ", seq.topology.triangles.size(),
                                " triangles have zero area in frame 0 (relative to the mesh's extent, (", Num(lo.x),
                                ", ", Num(lo.y), ", ", Num(lo.z), ") to (", Num(hi.x), ", ", Num(hi.y), ", ", Num(hi.z),
                                "): a vertex far from the others?): there is no surface to resample"));
  }
  // An inside-out mesh is resampled from its back faces, which no camera
  // sees: the fit had no Samples and printed the initial guess, exit 0.
  const MeshOrientation orientation = ComputeMeshOrientation(seq.topology, seq.rest_positions);
  // Negative beyond rounding: a flat closed (double-sided) mesh encloses ~0.
  if (orientation.closed && orientation.signed_volume < -1e-9 * orientation.diagonal_cubed) {
    return Invalid(mesh_field,
                   absl::StrCat("the mesh is closed and its triangles face inwards (signed volume ",
                                Num(orientation.signed_volume / 6.0), " in frame 0, expected > 0: counter-clockwise "
                                "seen from outside); set scene.mesh.flipWinding to true to reverse them",
                                scene.mesh().flip_winding() ? " (it is true: the file's winding faces outwards)" : ""));
  }
  if (options.check_all_frames && !seq.is_static_mesh()) {
    for (int t = 1; t < seq.num_frames; ++t) MVBRDF_RETURN_IF_ERROR(seq.LoadFrame(t).status());
  }
  if (!scene.segmentation_path().empty()) MVBRDF_RETURN_IF_ERROR(CheckSegmentation(seq));
  if (options.probe_videos) {
    for (int i = 0; i < scene.cameras_size(); ++i) MVBRDF_RETURN_IF_ERROR(ProbeVideo(seq, i));
  }
  if (options.read_every_video_frame) {
    for (int i = 0; i < scene.cameras_size(); ++i) MVBRDF_RETURN_IF_ERROR(ReadEveryVideoFrame(seq, i));
  }
  for (const v1::Camera& camera : scene.cameras()) seq.cameras.push_back(CameraModelFromProto(camera));
  for (int i = 0; i < scene.cameras_size(); ++i) MVBRDF_RETURN_IF_ERROR(CheckCameraSeesMesh(seq, i));
  if (!options.check_all_frames && !seq.is_static_mesh()) MVBRDF_RETURN_IF_ERROR(CheckMeshFramesExist(seq));
  for (const v1::Light& light : scene.lights()) seq.lights.push_back(LightFromProto(light));
  return seq;
}

}  // namespace

absl::StatusOr<Sequence> LoadSequence(const std::filesystem::path& scene_file, const LoadOptions& options) {
  absl::StatusOr<Sequence> seq = LoadAndCheck(scene_file, options);
  if (seq.ok()) return seq;
  return InSceneTerms(seq.status(), scene_file.has_parent_path() ? scene_file.parent_path() : ".");
}

std::string Summarize(const Sequence& seq) {
  const v1::Scene& scene = seq.scene;
  const MeshTopology& topo = seq.topology;
  std::string s;
  // Free-form, unbounded: a 10 MB name made a 10 MB summary line.
  absl::StrAppend(&s, "Scene: ", scene.name().empty() ? "(unnamed)" : ElideForMessage(scene.name(), 200), "\n");
  absl::StrAppend(&s, "  file: ", seq.scene_file.string(), "\n");
  absl::StrAppend(&s, "Frames: ", seq.num_frames, " from frame ", seq.AbsoluteFrame(0), " at ",
                  Num(scene.frames().fps()), " fps (", Num(seq.num_frames / scene.frames().fps()), " s)");
  if (!seq.frames.indices.empty()) {
    absl::StrAppend(&s, ", the listed frames.indices up to frame ", seq.AbsoluteFrame(seq.num_frames - 1));
  } else if (seq.frames.step > 1) {
    absl::StrAppend(&s, ", file frames first + t * ", seq.frames.step, " up to frame ", seq.AbsoluteFrame(seq.num_frames - 1));
  }
  absl::StrAppend(&s, "\n");
  absl::StrAppend(&s, "Mesh: ", scene.mesh().path(), seq.is_static_mesh() ? " (static)" : " (one file per frame)",
                  "\n");
  absl::StrAppend(&s, "  ", topo.num_file_vertices, " file vertices, ", topo.num_render_vertices(),
                  " render vertices, ", topo.triangles.size(), " triangles\n");
  absl::StrAppend(&s, "  UVs: ", topo.has_uvs() ? "yes (from the mesh file)" : "no (an atlas will be built)", "\n");
  if (!topo.clamped_uv_vertices.empty()) {
    absl::StrAppend(&s, "  clamped UVs: ", topo.clamped_uv_vertices.size(), " render vertices had UVs up to ",
                    Num(kMaxUvExcursion), " outside [0,1]^2\n");
  }
  if (topo.zero_area_triangles.empty()) {
    absl::StrAppend(&s, "  zero-area triangles: none\n");
  } else {
    std::vector<uint32_t> head(
        topo.zero_area_triangles.begin(),
        topo.zero_area_triangles.begin() + std::min<size_t>(10, topo.zero_area_triangles.size()));
    absl::StrAppend(&s, "  zero-area triangles: ", topo.zero_area_triangles.size(),
                    " excluded from resampling and fitting (", absl::StrJoin(head, ", "),
                    topo.zero_area_triangles.size() > head.size() ? ", ..." : "", ")\n");
  }
  absl::StrAppend(&s, "Cameras: ", seq.cameras.size(), "\n");
  for (int i = 0; i < scene.cameras_size(); ++i) {
    const v1::Camera& c = scene.cameras(i);
    const CameraModel& m = seq.cameras[static_cast<size_t>(i)];
    const glm::dvec3 centre = m.CenterInWorld();
    const std::string scale = m.orthographic() ? absl::StrCat("orthographic, pixel size ", Num(m.pixel_size))
                                               : absl::StrCat("f = (", Num(m.fx), ", ", Num(m.fy), ") px");
    absl::StrAppend(&s, "  ", c.name(), ": ", c.width(), "x", c.height(), ", ", scale, ", centre (", Num(centre.x),
                    ", ", Num(centre.y), ", ", Num(centre.z), ")", m.has_distortion() ? ", distorted" : "", ", video ",
                    c.video().path(), " (", c.video().encoding() == v1::LINEAR ? "linear" : "sRGB", ", ",
                    c.video().bit_depth() == 0 ? 8u : c.video().bit_depth(), "-bit",
                    c.video().mask_path().empty() ? "" : absl::StrCat(", mask ", c.video().mask_path()),
                    c.video().has_saturation_level()
                        ? absl::StrCat(", saturated at ", c.video().saturation_level())
                        : absl::StrCat(", saturated at ", c.video().bit_depth() == 16 ? 65535 : 255, " (default)"),
                    c.video().frame_offset() == 0
                        ? ""
                        : absl::StrCat(", frame offset ", c.video().frame_offset(), ": sequence frame f is its frame f ",
                                       c.video().frame_offset() > 0 ? "+ " : "- ", std::abs(c.video().frame_offset())),
                    ")\n");
  }
  absl::StrAppend(&s, "Lights: ", seq.lights.size(),
                  scene.lighting().inverse_square_falloff() ? " (inverse-square fall-off)" : "", "\n");
  for (const Light& l : seq.lights) {
    const glm::vec3 v = l.directional ? l.direction : l.position;
    absl::StrAppend(&s, "  ", l.name, ": ", l.directional ? "directional towards (" : "point at (", Num(v.x), ", ",
                    Num(v.y), ", ", Num(v.z), "), intensity (", Num(l.intensity.x), ", ", Num(l.intensity.y), ", ",
                    Num(l.intensity.z), ")\n");
  }
  for (int i = 0; i < scene.lights_size(); ++i) {
    const auto& d = scene.lights(i).direction();
    if (d.size() != 3) continue;
    const double length = std::sqrt(d.Get(0) * d.Get(0) + d.Get(1) * d.Get(1) + d.Get(2) * d.Get(2));
    if (std::abs(length - 1.0) > kUnitLengthTolerance) {
      absl::StrAppend(&s, "  note: scene.lights[", i, "].direction has length ", Num(length),
                      ", renormalised to unit length\n");
    }
  }
  absl::StrAppend(&s, "Light configurations: ", scene.light_configurations_size(), "\n");
  for (const v1::LightConfiguration& c : scene.light_configurations()) {
    absl::StrAppend(&s, "  ", c.name(), ": ", absl::StrJoin(c.lights(), ", "), "\n");
  }
  int lit_own = 0;
  for (int t = 0; t < seq.num_frames; ++t) lit_own += seq.FrameLightingOf(t) != nullptr ? 1 : 0;
  if (scene.frame_lighting_size() != 0) {
    absl::StrAppend(&s, "Frame lighting: ", lit_own, " frames with their own lights",
                    seq.every_frame_lit_own()
                        ? " (every frame: no configuration to choose, no light sweep)\n"
                        : " (the others: all lights of the configuration)\n");
  }
  if (lit_own != scene.frame_lighting_size()) {
    absl::StrAppend(&s, "  note: ", scene.frame_lighting_size() - lit_own,
                    " scene.frame_lighting entries are for frames the selection skips: ignored\n");
  }
  absl::StrAppend(&s, "Material seeds: ", scene.material_seeds_size(), "\n");
  for (const v1::MaterialSeed& m : scene.material_seeds()) {
    absl::StrAppend(&s, "  ", m.name(), ": sRGB (", absl::StrJoin(m.srgb8(), ", "), ")\n");
  }
  if (!scene.segmentation_path().empty()) {
    absl::StrAppend(&s, "Segmentation: ", scene.segmentation_path(), "\n");
    for (const v1::SegmentMaterials& m : scene.segment_materials()) {
      absl::StrAppend(&s, "  ", m.segment(), ": ", absl::StrJoin(m.materials(), ", "), "\n");
    }
  }
  return s;
}

}  // namespace mvbrdf::scene
