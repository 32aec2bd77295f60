#include "core/importers/opencv_calibration.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <initializer_list>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <set>
#include <string>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace mvbrdf::importers {
namespace {

absl::Status Invalid(const std::filesystem::path& file, absl::string_view key, absl::string_view message) {
  return absl::InvalidArgumentError(absl::StrCat(file.string(), ": ", key, ": ", message));
}

// The first of `aliases` present in `map` (its name in `used`), or a none node.
cv::FileNode Find(const cv::FileNode& map, std::initializer_list<const char*> aliases, std::string* used) {
  for (const char* alias : aliases) {
    cv::FileNode n = map[alias];
    if (!n.isNone()) {
      *used = alias;
      return n;
    }
  }
  *used = *aliases.begin();
  return cv::FileNode();
}

// Two aliases of one key given at once (e.g. R and rvec): which one was meant
// is not guessed.
absl::Status CheckOnlyOne(const std::filesystem::path& file, const cv::FileNode& map,
                          std::initializer_list<const char*> aliases) {
  std::vector<std::string> present;
  for (const char* alias : aliases) {
    if (!map[alias].isNone()) present.push_back(alias);
  }
  if (present.size() > 1) {
    return Invalid(
        file, present[0],
        absl::StrCat("given together with ", absl::StrJoin(present.begin() + 1, present.end(), ", "), "; keep one"));
  }
  return absl::OkStatus();
}

absl::StatusOr<double> Number(const std::filesystem::path& file, const std::string& key, const cv::FileNode& n) {
  if (!n.isInt() && !n.isReal()) return Invalid(file, key, "must be a number");
  const double v = static_cast<double>(n);
  if (!std::isfinite(v)) return Invalid(file, key, "must be finite");
  return v;
}

// A matrix's values, row-major: an OpenCV matrix (rows, cols, dt, data) or a
// plain sequence (flat or of rows). `rows`/`cols` is the size found.
absl::StatusOr<std::vector<double>> Values(const std::filesystem::path& file, const std::string& key,
                                           const cv::FileNode& n, int* rows, int* cols) {
  std::vector<double> values;
  auto add = [&](const cv::FileNode& v, const std::string& where) -> absl::Status {
    auto x = Number(file, where, v);
    if (!x.ok()) return x.status();
    values.push_back(*x);
    return absl::OkStatus();
  };
  if (n.isMap()) {
    const cv::FileNode r = n["rows"], c = n["cols"], data = n["data"];
    if (!r.isInt() || !c.isInt() || !data.isSeq()) {
      return Invalid(file, key, "a map must be an OpenCV matrix with rows, cols and data");
    }
    *rows = static_cast<int>(r);
    *cols = static_cast<int>(c);
    const cv::FileNode dt = n["dt"];
    if (dt.isString() &&
        (dt.string().size() != 1 || std::string("ucwsifd").find(dt.string()[0]) == std::string::npos)) {
      return Invalid(file, key,
                     absl::StrCat("must have one channel (dt a single type letter), got dt \"", dt.string(), "\""));
    }
    for (size_t i = 0; i < data.size(); ++i) {
      if (absl::Status s = add(data[static_cast<int>(i)], absl::StrCat(key, ".data[", i, "]")); !s.ok()) return s;
    }
    if (values.size() != static_cast<size_t>(*rows) * static_cast<size_t>(*cols)) {
      return Invalid(file, key, absl::StrCat("has ", values.size(), " data values for ", *rows, "x", *cols));
    }
    return values;
  }
  if (n.isSeq()) {
    const bool nested = n.size() > 0 && n[0].isSeq();
    *rows = nested ? static_cast<int>(n.size()) : 1;
    *cols = nested ? 0 : static_cast<int>(n.size());
    for (size_t i = 0; i < n.size(); ++i) {
      const cv::FileNode e = n[static_cast<int>(i)];
      const std::string where = absl::StrCat(key, "[", i, "]");
      if (!nested) {
        if (absl::Status s = add(e, where); !s.ok()) return s;
        continue;
      }
      if (!e.isSeq()) return Invalid(file, where, "must be a row (a sequence of numbers) like the others");
      if (i == 0) *cols = static_cast<int>(e.size());
      if (static_cast<int>(e.size()) != *cols) {
        return Invalid(file, where, absl::StrCat("has ", e.size(), " values, row 0 has ", *cols));
      }
      for (size_t j = 0; j < e.size(); ++j) {
        if (absl::Status s = add(e[static_cast<int>(j)], absl::StrCat(where, "[", j, "]")); !s.ok()) return s;
      }
    }
    return values;
  }
  return Invalid(file, key, "must be a matrix (an OpenCV matrix or a sequence of numbers)");
}

// Exactly rows x cols values: an OpenCV matrix of that size, a sequence of
// rows, or a flat sequence of rows * cols numbers; a vector may be a row or a
// column.
absl::StatusOr<std::vector<double>> Matrix(const std::filesystem::path& file, const std::string& key,
                                           const cv::FileNode& n, int rows, int cols) {
  int r = 0, c = 0;
  auto values = Values(file, key, n, &r, &c);
  if (!values.ok()) return values.status();
  const size_t count = static_cast<size_t>(rows) * static_cast<size_t>(cols);
  const bool vector_ok = (rows == 1 || cols == 1) && (r == 1 || c == 1) && values->size() == count;
  const bool flat_ok = !n.isMap() && r == 1 && values->size() == count;
  if (!vector_ok && !flat_ok && !(r == rows && c == cols)) {
    return Invalid(file, key, absl::StrCat("must be ", rows, "x", cols, ", got ", r, "x", c));
  }
  return values;
}

// Where a camera's keys are: the file, and "cameras[i]." inside a sequence.
struct Place {
  std::filesystem::path file;
  std::string prefix;
  std::string Key(absl::string_view alias) const { return absl::StrCat(prefix, alias); }
};

absl::StatusOr<uint32_t> WholeSize(const Place& at, const std::string& key, double v) {
  if (!(v >= 1 && v <= 1e6) || v != std::floor(v)) {
    return Invalid(at.file, key, absl::StrCat("must be a positive whole number of pixels, got ", v));
  }
  return static_cast<uint32_t>(v);
}

absl::StatusOr<uint32_t> ImageSize(const Place& at, const cv::FileNode& map, int index,
                                   std::initializer_list<const char*> aliases) {
  std::string alias;
  if (cv::FileNode n = Find(map, aliases, &alias); !n.isNone()) {
    auto v = Number(at.file, at.Key(alias), n);
    if (!v.ok()) return v.status();
    return WholeSize(at, at.Key(alias), *v);
  }
  std::string size_alias;
  cv::FileNode size = Find(map, {"image_size", "imageSize"}, &size_alias);
  if (size.isNone()) {
    return Invalid(at.file, at.Key(alias), "missing (or give image_size: [width, height])");
  }
  auto wh = Matrix(at.file, at.Key(size_alias), size, 1, 2);
  if (!wh.ok()) return wh.status();
  return WholeSize(at, absl::StrCat(at.Key(size_alias), "[", index, "]"), (*wh)[index]);
}

absl::StatusOr<v1::Camera> ReadCamera(const Place& at, const cv::FileNode& map, const std::string& default_name) {
  const std::filesystem::path& file = at.file;
  v1::Camera camera;
  camera.set_model(v1::PINHOLE);
  if (cv::FileNode name = map["name"]; !name.isNone()) {
    if (!name.isString() || name.string().empty()) return Invalid(file, at.Key("name"), "must be a non-empty string");
    camera.set_name(name.string());
  } else if (default_name.empty()) {
    return Invalid(file, at.Key("name"), "missing (each entry of `cameras` needs a name)");
  } else {
    camera.set_name(default_name);
  }

  auto width = ImageSize(at, map, 0, {"image_width", "width", "imageWidth"});
  if (!width.ok()) return width.status();
  auto height = ImageSize(at, map, 1, {"image_height", "height", "imageHeight"});
  if (!height.ok()) return height.status();
  camera.set_width(*width);
  camera.set_height(*height);

  // Intrinsics.
  const auto k_aliases = {"camera_matrix", "K", "cameraMatrix", "intrinsics"};
  if (absl::Status s = CheckOnlyOne(file, map, k_aliases); !s.ok()) return s;
  std::string alias;
  cv::FileNode k_node = Find(map, k_aliases, &alias);
  if (k_node.isNone()) return Invalid(file, at.Key(alias), "missing (the 3x3 camera matrix; aliases K, cameraMatrix)");
  auto k = Matrix(file, at.Key(alias), k_node, 3, 3);
  if (!k.ok()) return k.status();
  const std::vector<double>& K = *k;
  if (K[1] != 0.0)
    return Invalid(file, at.Key(alias), absl::StrCat("has skew K[0][1] = ", K[1], "; mvbrdf's cameras have none"));
  if (K[3] != 0.0 || K[6] != 0.0 || K[7] != 0.0 || K[8] != 1.0) {
    return Invalid(file, at.Key(alias), "must be [fx 0 cx; 0 fy cy; 0 0 1]");
  }
  if (!(K[0] > 0.0) || !(K[4] > 0.0)) return Invalid(file, at.Key(alias), "fx and fy must be positive");
  // OpenCV's pixel (0,0) is the centre of the top-left pixel, as in mvbrdf:
  // cx, cy need no half-pixel shift.
  v1::Intrinsics* intrinsics = camera.mutable_intrinsics();
  intrinsics->set_fx(K[0]);
  intrinsics->set_fy(K[4]);
  intrinsics->set_cx(K[2]);
  intrinsics->set_cy(K[5]);

  const auto d_aliases = {"distortion_coefficients", "D", "dist", "distCoeffs", "dist_coeffs", "distortion"};
  if (absl::Status s = CheckOnlyOne(file, map, d_aliases); !s.ok()) return s;
  if (cv::FileNode d_node = Find(map, d_aliases, &alias); !d_node.isNone()) {
    int r = 0, c = 0;
    auto d = Values(file, at.Key(alias), d_node, &r, &c);
    if (!d.ok()) return d.status();
    if (r != 1 && c != 1) return Invalid(file, at.Key(alias), absl::StrCat("must be a vector, got ", r, "x", c));
    std::vector<double> coefficients = *d;
    // OpenCV's 12 and 14 coefficient models (thin prism, tilt) only when
    // their extra terms are 0; trailing zeros never change the model.
    auto all_zero_from = [&](size_t n) {
      return std::all_of(coefficients.begin() + std::min(n, coefficients.size()), coefficients.end(),
                         [](double v) { return v == 0.0; });
    };
    size_t keep = coefficients.size();
    for (size_t n : {size_t{0}, size_t{4}, size_t{5}, size_t{8}}) {
      if (n <= coefficients.size() && all_zero_from(n)) {
        keep = n;
        break;
      }
    }
    if (keep != 0 && keep != 4 && keep != 5 && keep != 8) {
      return Invalid(file, at.Key(alias),
                     absl::StrCat("has ", coefficients.size(),
                                  " coefficients; mvbrdf takes OpenCV's k1, k2, p1, p2[, k3[, k4, k5, k6]] (4, 5 or 8; "
                                  "more only when the extra ones are 0)"));
    }
    coefficients.resize(keep);
    for (double v : coefficients) intrinsics->add_distortion(v);
  }

  // Extrinsics.
  const auto r_aliases = {"R", "rotation", "rotation_matrix"};
  const auto rvec_aliases = {"rvec", "rvecs"};
  const auto t_aliases = {"T", "tvec", "t", "translation", "tvecs"};
  for (auto aliases :
       {std::initializer_list<const char*>{"R", "rotation", "rotation_matrix", "rvec", "rvecs"}, t_aliases}) {
    if (absl::Status s = CheckOnlyOne(file, map, aliases); !s.ok()) return s;
  }
  std::array<double, 9> R{};
  std::string r_alias;
  cv::FileNode r_node = Find(map, r_aliases, &r_alias);
  if (!r_node.isNone()) {
    auto r = Matrix(file, at.Key(r_alias), r_node, 3, 3);
    if (!r.ok()) return r.status();
    std::copy(r->begin(), r->end(), R.begin());
  } else if (cv::FileNode rvec_node = Find(map, rvec_aliases, &r_alias); !rvec_node.isNone()) {
    auto rvec = Matrix(file, at.Key(r_alias), rvec_node, 3, 1);
    if (!rvec.ok()) return rvec.status();
    cv::Mat rotation;
    cv::Rodrigues(cv::Mat(3, 1, CV_64F, rvec->data()).clone(), rotation);
    for (int i = 0; i < 9; ++i) R[i] = rotation.at<double>(i / 3, i % 3);
  } else {
    return Invalid(file, at.Key("R"),
                   "missing (the world-to-camera rotation: R as a 3x3 matrix or rvec as a Rodrigues vector)");
  }
  std::string t_alias;
  cv::FileNode t_node = Find(map, t_aliases, &t_alias);
  if (t_node.isNone())
    return Invalid(file, at.Key("T"), "missing (the world-to-camera translation, 3 values; alias tvec)");
  auto t = Matrix(file, at.Key(t_alias), t_node, 3, 1);
  if (!t.ok()) return t.status();
  std::array<double, 3> T{(*t)[0], (*t)[1], (*t)[2]};

  if (cv::FileNode convention = map["extrinsics_convention"]; !convention.isNone()) {
    const std::string value = convention.isString() ? convention.string() : "";
    if (value == "camera_to_world") {
      // R, T take camera points into the world: invert (R^T, -R^T T).
      std::array<double, 9> Rt{};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) Rt[i * 3 + j] = R[j * 3 + i];
      std::array<double, 3> tt{};
      for (int i = 0; i < 3; ++i) tt[i] = -(Rt[i * 3] * T[0] + Rt[i * 3 + 1] * T[1] + Rt[i * 3 + 2] * T[2]);
      R = Rt;
      T = tt;
    } else if (value != "world_to_camera") {
      return Invalid(file, at.Key("extrinsics_convention"), "must be \"world_to_camera\" or \"camera_to_world\"");
    }
  }
  v1::CamFromWorld* pose = camera.mutable_cam_from_world();
  for (double v : R) pose->add_rotation(v);
  for (double v : T) pose->add_translation(v);
  return camera;
}

bool IsCalibrationFile(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".yml" || ext == ".yaml" || ext == ".json" || ext == ".xml";
}

absl::Status ReadFile(const std::filesystem::path& file, std::vector<v1::Camera>* cameras) {
  try {
    cv::FileStorage fs;
    if (!fs.open(file.string(), cv::FileStorage::READ) || !fs.isOpened()) {
      return absl::InvalidArgumentError(
          absl::StrCat(file.string(), ": not readable as an OpenCV FileStorage file (YAML, JSON or XML)"));
    }
    const cv::FileNode root = fs.root();
    if (cv::FileNode list = root["cameras"]; !list.isNone()) {
      if (!list.isSeq() || list.size() == 0) return Invalid(file, "cameras", "must be a non-empty sequence of maps");
      for (size_t i = 0; i < list.size(); ++i) {
        const Place at{file, absl::StrCat("cameras[", i, "].")};
        const cv::FileNode entry = list[static_cast<int>(i)];
        if (!entry.isMap()) return Invalid(file, absl::StrCat("cameras[", i, "]"), "must be a map");
        auto camera = ReadCamera(at, entry, "");
        if (!camera.ok()) return camera.status();
        cameras->push_back(*std::move(camera));
      }
      return absl::OkStatus();
    }
    auto camera = ReadCamera(Place{file, ""}, root, file.stem().string());
    if (!camera.ok()) return camera.status();
    cameras->push_back(*std::move(camera));
    return absl::OkStatus();
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat(file.string(), ": not a valid OpenCV FileStorage file: ", e.what()));
  }
}

}  // namespace

absl::StatusOr<std::vector<v1::Camera>> ReadOpenCvCalibration(const std::filesystem::path& file_or_dir) {
  std::error_code ec;
  std::vector<std::filesystem::path> files;
  if (std::filesystem::is_directory(file_or_dir, ec)) {
    for (const auto& entry : std::filesystem::directory_iterator(file_or_dir, ec)) {
      if (entry.is_regular_file(ec) && IsCalibrationFile(entry.path())) files.push_back(entry.path());
    }
    if (ec) return absl::InvalidArgumentError(absl::StrCat(file_or_dir.string(), ": cannot list: ", ec.message()));
    std::sort(files.begin(), files.end());
    if (files.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat(file_or_dir.string(), ": no *.yml, *.yaml, *.json or *.xml calibration file in the directory"));
    }
  } else if (std::filesystem::exists(file_or_dir, ec)) {
    files.push_back(file_or_dir);
  } else {
    return absl::NotFoundError(absl::StrCat(file_or_dir.string(), ": no such file or directory"));
  }
  std::vector<v1::Camera> cameras;
  for (const auto& file : files) {
    if (absl::Status s = ReadFile(file, &cameras); !s.ok()) return s;
  }
  std::set<std::string> names;
  for (const v1::Camera& camera : cameras) {
    if (!names.insert(camera.name()).second) {
      return absl::InvalidArgumentError(absl::StrCat(file_or_dir.string(), ": camera name \"", camera.name(),
                                                     "\" is given twice (names must be unique)"));
    }
  }
  return cameras;
}

}  // namespace mvbrdf::importers
