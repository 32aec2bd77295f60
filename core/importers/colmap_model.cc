#include "core/importers/colmap_model.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <utility>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"
#include "core/scene/names.h"

namespace mvbrdf::importers {
namespace {

// COLMAP's camera models: name, model id in the binary files, number of
// parameters (colmap/sensor/models.h).
struct ColmapModel {
  const char* name;
  int id;
  int num_params;
  bool supported;
};
constexpr ColmapModel kModels[] = {
    {"SIMPLE_PINHOLE", 0, 3, true},
    {"PINHOLE", 1, 4, true},
    {"SIMPLE_RADIAL", 2, 4, true},
    {"RADIAL", 3, 5, true},
    {"OPENCV", 4, 8, true},
    {"OPENCV_FISHEYE", 5, 8, false},
    {"FULL_OPENCV", 6, 12, true},
    {"FOV", 7, 5, false},
    {"SIMPLE_RADIAL_FISHEYE", 8, 4, false},
    {"RADIAL_FISHEYE", 9, 5, false},
    {"THIN_PRISM_FISHEYE", 10, 12, false},
    {"RAD_TAN_THIN_PRISM_FISHEYE", 11, 16, false},
};

const ColmapModel* FindModel(const std::string& name) {
  for (const ColmapModel& m : kModels) {
    if (name == m.name) return &m;
  }
  return nullptr;
}
const ColmapModel* FindModel(int id) {
  for (const ColmapModel& m : kModels) {
    if (id == m.id) return &m;
  }
  return nullptr;
}

constexpr char kSupported[] = "SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV or FULL_OPENCV";

absl::Status Invalid(const std::string& where, const std::string& message) {
  return absl::InvalidArgumentError(absl::StrCat(where, ": ", message));
}

// What a COLMAP camera is before it meets an image.
struct RawCamera {
  uint64_t width = 0;
  uint64_t height = 0;
  v1::Intrinsics intrinsics;
};

// What an image contributes: its pose, its camera, its name, where it was read.
struct RawImage {
  uint32_t camera_id = 0;
  std::array<double, 4> q{};
  std::array<double, 3> t{};
  std::string name;
  std::string where;
};

struct RawModel {
  std::map<uint32_t, RawCamera> cameras;
  std::map<uint32_t, RawImage> images;  // by IMAGE_ID: the cameras' order
};

absl::StatusOr<double> ParseFinite(absl::string_view token, const std::string& where, absl::string_view what) {
  double v = 0.0;
  if (!absl::SimpleAtod(token, &v) || !std::isfinite(v)) {
    return Invalid(where, absl::StrCat(what, ": expected a finite number, got \"", scene::ShownName(token), "\""));
  }
  return v;
}

template <typename T>
absl::StatusOr<T> ParseInteger(absl::string_view token, const std::string& where, absl::string_view what) {
  T v = 0;
  if (!absl::SimpleAtoi(token, &v)) {
    return Invalid(where,
                   absl::StrCat(what, ": expected a non-negative integer, got \"", scene::ShownName(token), "\""));
  }
  return v;
}

// ---- text model ------------------------------------------------------------

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines = absl::StrSplit(text, '\n');
  for (std::string& line : lines) {
    absl::string_view s = absl::StripAsciiWhitespace(line);  // also "\r"
    line = std::string(s);
  }
  return lines;
}

std::vector<absl::string_view> Tokens(const std::string& line) {
  return absl::StrSplit(line, absl::ByAnyChar(" \t"), absl::SkipEmpty());
}

absl::Status ReadCamerasText(const std::filesystem::path& file, RawModel* model) {
  MVBRDF_ASSIGN_OR_RETURN(const std::string text, ReadFileToString(file));
  const std::vector<std::string> lines = Lines(text);
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string& line = lines[i];
    if (line.empty() || line[0] == '#') continue;
    const std::string where = absl::StrCat(file.string(), ":", i + 1);
    const std::vector<absl::string_view> tokens = Tokens(line);
    if (tokens.size() < 4) {
      return Invalid(where,
                     absl::StrCat("expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[], got ", tokens.size(), " fields"));
    }
    MVBRDF_ASSIGN_OR_RETURN(const uint32_t id, ParseInteger<uint32_t>(tokens[0], where, "CAMERA_ID"));
    RawCamera camera;
    MVBRDF_ASSIGN_OR_RETURN(camera.width, ParseInteger<uint64_t>(tokens[2], where, "WIDTH"));
    MVBRDF_ASSIGN_OR_RETURN(camera.height, ParseInteger<uint64_t>(tokens[3], where, "HEIGHT"));
    std::vector<double> params;
    for (size_t k = 4; k < tokens.size(); ++k) {
      MVBRDF_ASSIGN_OR_RETURN(const double v, ParseFinite(tokens[k], where, absl::StrCat("PARAMS[", k - 4, "]")));
      params.push_back(v);
    }
    MVBRDF_ASSIGN_OR_RETURN(camera.intrinsics, IntrinsicsFromColmap(std::string(tokens[1]), params, where));
    if (!model->cameras.emplace(id, std::move(camera)).second) {
      return Invalid(where, absl::StrCat("CAMERA_ID ", id, " given twice"));
    }
  }
  return absl::OkStatus();
}

absl::Status ReadImagesText(const std::filesystem::path& file, RawModel* model) {
  MVBRDF_ASSIGN_OR_RETURN(const std::string text, ReadFileToString(file));
  const std::vector<std::string> lines = Lines(text);
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string& line = lines[i];
    if (line.empty() || line[0] == '#') continue;
    const std::string where = absl::StrCat(file.string(), ":", i + 1);
    const std::vector<absl::string_view> tokens = Tokens(line);
    if (tokens.size() != 10) {
      return Invalid(where, absl::StrCat("expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME (10 fields), got ",
                                         tokens.size()));
    }
    MVBRDF_ASSIGN_OR_RETURN(const uint32_t id, ParseInteger<uint32_t>(tokens[0], where, "IMAGE_ID"));
    RawImage image;
    static constexpr const char* kQ[] = {"QW", "QX", "QY", "QZ"};
    static constexpr const char* kT[] = {"TX", "TY", "TZ"};
    for (int k = 0; k < 4; ++k) {
      MVBRDF_ASSIGN_OR_RETURN(image.q[k], ParseFinite(tokens[1 + k], where, kQ[k]));
    }
    for (int k = 0; k < 3; ++k) {
      MVBRDF_ASSIGN_OR_RETURN(image.t[k], ParseFinite(tokens[5 + k], where, kT[k]));
    }
    MVBRDF_ASSIGN_OR_RETURN(image.camera_id, ParseInteger<uint32_t>(tokens[8], where, "CAMERA_ID"));
    image.name = std::string(tokens[9]);
    image.where = where;
    if (!model->images.emplace(id, std::move(image)).second) {
      return Invalid(where, absl::StrCat("IMAGE_ID ", id, " given twice"));
    }
    // Every image line is followed by its POINTS2D line (X Y POINT3D_ID ...),
    // which may be empty: skipped unread, as COLMAP's own reader does.
    ++i;
  }
  return absl::OkStatus();
}

// ---- binary model ----------------------------------------------------------

// Little-endian reads from a whole file, bounds-checked.
class BinaryReader {
 public:
  BinaryReader(std::string data, std::string file) : data_(std::move(data)), file_(std::move(file)) {}

  // `what` names the value in the error when the file ends before it.
  template <typename T>
  absl::StatusOr<T> Read(absl::string_view what) {
    if (data_.size() - offset_ < sizeof(T)) return Truncated(what);
    T v;
    std::memcpy(&v, data_.data() + offset_, sizeof(T));  // x86/ARM little-endian, like COLMAP's files
    offset_ += sizeof(T);
    return v;
  }
  absl::StatusOr<std::string> ReadNulTerminated(absl::string_view what) {
    const size_t end = data_.find('\0', offset_);
    if (end == std::string::npos) return Truncated(what);
    std::string s = data_.substr(offset_, end - offset_);
    offset_ = end + 1;
    return s;
  }
  absl::Status Skip(uint64_t bytes, absl::string_view what) {
    if (data_.size() - offset_ < bytes) return Truncated(what);
    offset_ += bytes;
    return absl::OkStatus();
  }
  absl::Status ExpectEnd() const {
    if (offset_ == data_.size()) return absl::OkStatus();
    return Invalid(file_, absl::StrCat(data_.size() - offset_, " bytes after the last record (at byte ", offset_,
                                       "): not a COLMAP model file"));
  }
  const std::string& file() const { return file_; }
  size_t offset() const { return offset_; }

 private:
  absl::Status Truncated(absl::string_view what) const {
    return Invalid(file_, absl::StrCat("truncated: ends at byte ", data_.size(), " while reading ", what));
  }
  std::string data_;
  std::string file_;
  size_t offset_ = 0;
};

absl::Status ReadCamerasBinary(const std::filesystem::path& file, RawModel* model) {
  MVBRDF_ASSIGN_OR_RETURN(std::string data, ReadFileToString(file));
  BinaryReader in(std::move(data), file.string());
  MVBRDF_ASSIGN_OR_RETURN(const uint64_t count, in.Read<uint64_t>("the number of cameras"));
  for (uint64_t i = 0; i < count; ++i) {
    const std::string what = absl::StrCat("camera ", i + 1, " of ", count);
    const std::string where = absl::StrCat(file.string(), ": ", what, " (byte ", in.offset(), ")");
    MVBRDF_ASSIGN_OR_RETURN(const uint32_t id, in.Read<uint32_t>(what));
    MVBRDF_ASSIGN_OR_RETURN(const int32_t model_id, in.Read<int32_t>(what));
    RawCamera camera;
    MVBRDF_ASSIGN_OR_RETURN(camera.width, in.Read<uint64_t>(what));
    MVBRDF_ASSIGN_OR_RETURN(camera.height, in.Read<uint64_t>(what));
    const ColmapModel* m = FindModel(model_id);
    if (m == nullptr) {
      return Invalid(where, absl::StrCat("unknown camera model id ", model_id, " (expected ", kSupported, ")"));
    }
    std::vector<double> params(m->num_params);
    for (int k = 0; k < m->num_params; ++k) {
      MVBRDF_ASSIGN_OR_RETURN(params[k], in.Read<double>(what));
      if (!std::isfinite(params[k])) {
        return Invalid(where, absl::StrCat("PARAMS[", k, "]: expected a finite number, got ", params[k]));
      }
    }
    MVBRDF_ASSIGN_OR_RETURN(camera.intrinsics, IntrinsicsFromColmap(m->name, params, where));
    if (!model->cameras.emplace(id, std::move(camera)).second) {
      return Invalid(where, absl::StrCat("CAMERA_ID ", id, " given twice"));
    }
  }
  return in.ExpectEnd();
}

absl::Status ReadImagesBinary(const std::filesystem::path& file, RawModel* model) {
  MVBRDF_ASSIGN_OR_RETURN(std::string data, ReadFileToString(file));
  BinaryReader in(std::move(data), file.string());
  MVBRDF_ASSIGN_OR_RETURN(const uint64_t count, in.Read<uint64_t>("the number of images"));
  for (uint64_t i = 0; i < count; ++i) {
    const std::string what = absl::StrCat("image ", i + 1, " of ", count);
    const std::string where = absl::StrCat(file.string(), ": ", what, " (byte ", in.offset(), ")");
    MVBRDF_ASSIGN_OR_RETURN(const uint32_t id, in.Read<uint32_t>(what));
    RawImage image;
    for (double& q : image.q) {
      MVBRDF_ASSIGN_OR_RETURN(q, in.Read<double>(what));
    }
    for (double& t : image.t) {
      MVBRDF_ASSIGN_OR_RETURN(t, in.Read<double>(what));
    }
    for (double v : image.q) {
      if (!std::isfinite(v)) return Invalid(where, "QVEC: expected finite numbers");
    }
    for (double v : image.t) {
      if (!std::isfinite(v)) return Invalid(where, "TVEC: expected finite numbers");
    }
    MVBRDF_ASSIGN_OR_RETURN(image.camera_id, in.Read<uint32_t>(what));
    MVBRDF_ASSIGN_OR_RETURN(image.name, in.ReadNulTerminated(absl::StrCat(what, "'s name")));
    MVBRDF_ASSIGN_OR_RETURN(const uint64_t points, in.Read<uint64_t>(what));
    // POINTS2D: X, Y (double) and POINT3D_ID (int64) each; not needed.
    if (points > UINT64_MAX / 24) return Invalid(where, absl::StrCat("implausible number of points ", points));
    MVBRDF_RETURN_IF_ERROR(in.Skip(points * 24, absl::StrCat(what, "'s ", points, " points")));
    image.where = absl::StrCat(file.string(), ": ", what, " (\"", scene::ShownName(image.name), "\")");
    if (!model->images.emplace(id, std::move(image)).second) {
      return Invalid(where, absl::StrCat("IMAGE_ID ", id, " given twice"));
    }
  }
  return in.ExpectEnd();
}

// ---- model to cameras ------------------------------------------------------

absl::StatusOr<std::string> CameraName(const RawImage& image, ColmapCameraName naming) {
  const std::filesystem::path name(image.name);
  if (naming == ColmapCameraName::kStem) {
    if (name.stem().empty())
      return Invalid(image.where, absl::StrCat("image NAME \"", image.name, "\" has no file name"));
    return name.stem().string();
  }
  const std::string dir = name.parent_path().filename().string();
  if (dir.empty()) {
    return Invalid(image.where, absl::StrCat("image NAME \"", scene::ShownName(image.name),
                                             "\" has no directory to name its camera (--camera-name dir)"));
  }
  return dir;
}

absl::StatusOr<std::vector<v1::Camera>> ToCameras(const RawModel& model, const ColmapOptions& options) {
  std::vector<v1::Camera> cameras;
  std::map<std::string, const RawImage*> named;
  for (const auto& [id, image] : model.images) {
    const auto camera = model.cameras.find(image.camera_id);
    if (camera == model.cameras.end()) {
      return Invalid(image.where, absl::StrCat("CAMERA_ID ", image.camera_id, " is not in the cameras file"));
    }
    MVBRDF_ASSIGN_OR_RETURN(const std::string name, CameraName(image, options.camera_name));
    const auto [it, inserted] = named.emplace(name, &image);
    if (!inserted) {
      return Invalid(image.where, absl::StrCat("image \"", scene::ShownName(image.name), "\" and image \"",
                                               scene::ShownName(it->second->name), "\" (", it->second->where,
                                               ") both make camera \"", scene::ShownName(name),
                                               "\"; choose --camera-name stem or dir, or name the images uniquely"));
    }
    v1::Camera c;
    c.set_name(name);
    c.set_width(static_cast<uint32_t>(std::min<uint64_t>(camera->second.width, UINT32_MAX)));
    c.set_height(static_cast<uint32_t>(std::min<uint64_t>(camera->second.height, UINT32_MAX)));
    c.set_model(v1::PINHOLE);
    *c.mutable_intrinsics() = camera->second.intrinsics;
    absl::StatusOr<std::array<double, 9>> r = RotationFromQuaternion(image.q[0], image.q[1], image.q[2], image.q[3]);
    if (!r.ok()) return Invalid(image.where, std::string(r.status().message()));
    for (double v : *r) c.mutable_cam_from_world()->add_rotation(v);
    for (double v : image.t) c.mutable_cam_from_world()->add_translation(v);
    cameras.push_back(std::move(c));
  }
  if (cameras.empty()) return absl::InvalidArgumentError("the COLMAP model has no images (no camera poses)");
  return cameras;
}

}  // namespace

absl::StatusOr<std::array<double, 9>> RotationFromQuaternion(double w, double x, double y, double z) {
  const double norm = std::sqrt(w * w + x * x + y * y + z * z);
  if (!std::isfinite(norm) || norm < 1e-12) {
    return absl::InvalidArgumentError(
        absl::StrCat("quaternion QW QX QY QZ (", w, " ", x, " ", y, " ", z, ") has no rotation (norm ", norm, ")"));
  }
  w /= norm;
  x /= norm;
  y /= norm;
  z /= norm;
  return std::array<double, 9>{1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
                               2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                               2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
}

absl::StatusOr<v1::Intrinsics> IntrinsicsFromColmap(const std::string& model, const std::vector<double>& params,
                                                    const std::string& where) {
  const ColmapModel* m = FindModel(model);
  if (m == nullptr || !m->supported) {
    return Invalid(where, absl::StrCat(m == nullptr ? "unknown" : "unsupported", " camera model \"",
                                       scene::ShownName(model), "\" (expected ", kSupported, ")"));
  }
  if (static_cast<int>(params.size()) != m->num_params) {
    return Invalid(where, absl::StrCat(model, " takes ", m->num_params, " PARAMS, got ", params.size()));
  }
  v1::Intrinsics in;
  const std::string name = m->name;
  // Models with one focal length: f cx cy ...; the others fx fy cx cy ...
  const bool single_focal = name == "SIMPLE_PINHOLE" || name == "SIMPLE_RADIAL" || name == "RADIAL";
  const int c = single_focal ? 1 : 2;
  in.set_fx(params[0]);
  in.set_fy(single_focal ? params[0] : params[1]);
  // COLMAP's pixel (0,0) is the top-left pixel's corner (its centre at 0.5).
  in.set_cx(params[c] - 0.5);
  in.set_cy(params[c + 1] - 0.5);
  const std::vector<double> extra(params.begin() + c + 2, params.end());
  if (name == "SIMPLE_RADIAL") {
    for (double v : {extra[0], 0.0, 0.0, 0.0}) in.add_distortion(v);  // k1
  } else if (name == "RADIAL") {
    for (double v : {extra[0], extra[1], 0.0, 0.0}) in.add_distortion(v);  // k1 k2
  } else {
    for (double v : extra) in.add_distortion(v);  // OPENCV: k1 k2 p1 p2; FULL_OPENCV: + k3 k4 k5 k6
  }
  return in;
}

absl::StatusOr<std::vector<v1::Camera>> ReadColmapModel(const std::filesystem::path& model_dir,
                                                        const ColmapOptions& options) {
  auto has = [&](const char* name) { return std::filesystem::exists(model_dir / name); };
  const bool text = has("cameras.txt") || has("images.txt");
  const bool binary = has("cameras.bin") || has("images.bin");
  if (!std::filesystem::is_directory(model_dir)) {
    return absl::NotFoundError(absl::StrCat(model_dir.string(),
                                            ": not a directory (expected a COLMAP model "
                                            "directory holding cameras.txt and images.txt, or cameras.bin and "
                                            "images.bin)"));
  }
  if (text && binary) {
    return absl::InvalidArgumentError(absl::StrCat(model_dir.string(),
                                                   ": holds both a text (cameras.txt, images.txt) "
                                                   "and a binary model (cameras.bin, images.bin); keep one"));
  }
  if (!text && !binary) {
    return absl::NotFoundError(absl::StrCat(model_dir.string(),
                                            ": no COLMAP model (expected cameras.txt and "
                                            "images.txt, or cameras.bin and images.bin)"));
  }
  RawModel model;
  if (text) {
    MVBRDF_RETURN_IF_ERROR(ReadCamerasText(model_dir / "cameras.txt", &model));
    MVBRDF_RETURN_IF_ERROR(ReadImagesText(model_dir / "images.txt", &model));
  } else {
    MVBRDF_RETURN_IF_ERROR(ReadCamerasBinary(model_dir / "cameras.bin", &model));
    MVBRDF_RETURN_IF_ERROR(ReadImagesBinary(model_dir / "images.bin", &model));
  }
  return ToCameras(model, options);
}

}  // namespace mvbrdf::importers
