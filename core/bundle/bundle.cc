#include "core/bundle/bundle.h"

#include <archive.h>
#include <archive_entry.h>
#include <fcntl.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <memory>
#include <set>
#include <system_error>
#include <utility>

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "core/base/files.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/ground_truth.pb.h"

namespace mvbrdf::bundle {
namespace {

namespace fs = std::filesystem;

constexpr size_t kIoBlock = 1 << 16;
constexpr size_t kMaxPathLength = 4096;
constexpr int64_t kTarBlock = 512;

// ---- Packing ---------------------------------------------------------------

// `relative` (as written in `field`) checked to stay inside `base_dir`, which
// is `prefix` inside the bundle; returns the bundle path ("ground_truth/x").
absl::StatusOr<std::string> BundlePath(const fs::path& scene_dir, const std::string& prefix,
                                       const std::string& relative, const std::string& field) {
  const fs::path p(relative);
  if (p.has_root_path()) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": must be relative to the scene's folder (a bundle is "
                                                   "self-contained), got the absolute path \"", relative, "\""));
  }
  for (const fs::path& part : p) {
    if (part == "..") {
      return absl::InvalidArgumentError(absl::StrCat(
          field, ": must stay inside the scene's folder (a bundle is self-contained), got \"", relative, "\""));
    }
  }
  const std::string normal = (fs::path(prefix) / p).lexically_normal().generic_string();
  if (normal.empty() || normal == "." || absl::EndsWith(normal, "/")) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": not a file path: \"", relative, "\""));
  }
  // The file must exist, be a regular file, and (through any symlinks) lie
  // inside the scene's folder.
  const fs::path file = scene_dir / normal;
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) {
    if (fs::exists(file, ec)) {
      return absl::InvalidArgumentError(absl::StrCat(field, ": not a regular file: ", file.string()));
    }
    return absl::NotFoundError(absl::StrCat(field, ": file not found: ", file.string()));
  }
  // The same check and message as validate and run --direct (core/scene).
  MVBRDF_RETURN_IF_ERROR(scene::CheckResolvesInsideSceneDir(scene_dir, normal, field));
  return normal;
}

// Every file of a path that may be a frame pattern: the selected frames
// (scene.frames: first + t * step, or indices), t in [0, count).
absl::Status AddFrames(const fs::path& scene_dir, const std::string& path, const std::string& field,
                       const scene::FrameSelection& selection, int count, std::set<std::string>* files) {
  if (!IsFramePattern(path)) {
    MVBRDF_ASSIGN_OR_RETURN(std::string file, BundlePath(scene_dir, "", path, field));
    files->insert(std::move(file));
    return absl::OkStatus();
  }
  for (int i = 0; i < count; ++i) {
    const int t = selection.Absolute(i);
    MVBRDF_ASSIGN_OR_RETURN(std::string file, BundlePath(scene_dir, "", FormatFramePattern(path, t),
                                                         absl::StrCat(field, " (frame ", t, ")")));
    files->insert(std::move(file));
  }
  return absl::OkStatus();
}

// RFC 3986 percent-decoding of a glTF URI ("my%20mesh.bin"); false for a
// malformed escape.
bool PercentDecode(absl::string_view uri, std::string* out) {
  out->clear();
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] != '%') {
      out->push_back(uri[i]);
      continue;
    }
    if (i + 2 >= uri.size() || !absl::ascii_isxdigit(uri[i + 1]) || !absl::ascii_isxdigit(uri[i + 2])) return false;
    out->push_back(static_cast<char>(std::stoi(std::string(uri.substr(i + 1, 2)), nullptr, 16)));
    i += 2;
  }
  return true;
}

// The external files a text glTF mesh (bundle path `mesh`) references - its
// buffers' and images' URIs, relative to the mesh's folder - checked like
// every other file to stay inside the scene's folder. Embedded data: URIs
// need nothing. Without this a glTF with an external .bin ran with --direct
// but not through the service (the bundle lacked the buffer).
absl::Status AddGltfReferences(const fs::path& scene_dir, const std::string& mesh, const std::string& field,
                               std::set<std::string>* files) {
  constexpr uintmax_t kMaxGltfJsonBytes = uintmax_t{64} << 20;
  std::error_code ec;
  const uintmax_t size = fs::file_size(scene_dir / mesh, ec);
  if (ec || size > kMaxGltfJsonBytes) return absl::OkStatus();  // the mesh loader says what is wrong
  MVBRDF_ASSIGN_OR_RETURN(const std::string text, ReadFileToString(scene_dir / mesh));
  google::protobuf::Struct gltf;
  if (!google::protobuf::util::JsonStringToMessage(text, &gltf).ok()) return absl::OkStatus();  // likewise
  const fs::path folder = fs::path(mesh).parent_path();
  for (const char* array : {"buffers", "images"}) {
    const auto it = gltf.fields().find(array);
    if (it == gltf.fields().end() || !it->second.has_list_value()) continue;
    const google::protobuf::ListValue& list = it->second.list_value();
    for (int i = 0; i < list.values_size(); ++i) {
      if (!list.values(i).has_struct_value()) continue;
      const auto uri = list.values(i).struct_value().fields().find("uri");
      if (uri == list.values(i).struct_value().fields().end() || !uri->second.has_string_value()) continue;
      const std::string& value = uri->second.string_value();
      const std::string where = absl::StrCat(field, ": ", mesh, ": ", array, "[", i, "].uri");
      if (absl::StartsWith(value, "data:")) continue;
      std::string decoded;
      if (!PercentDecode(value, &decoded) || decoded.empty() || decoded.find('\0') != std::string::npos) {
        return absl::InvalidArgumentError(absl::StrCat(where, ": not a valid URI: \"", absl::CEscape(value), "\""));
      }
      if (absl::StrContains(decoded, "://")) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ": must be a file beside the mesh (a bundle is self-contained), got \"", value, "\""));
      }
      // The loader (assimp) opens the URI as written; the standard says it is
      // percent-encoded: the written one when that file exists, else the
      // decoded one. Relative to the mesh's folder; may climb out of it, not
      // out of the scene's.
      for (const std::string* name : {&value, static_cast<const std::string*>(&decoded)}) {
        const fs::path joined = (folder / fs::path(*name)).lexically_normal();
        if (fs::path(*name).has_root_path() || joined.empty() || *joined.begin() == "..") {
          return absl::InvalidArgumentError(absl::StrCat(
              where, ": must stay inside the scene's folder (a bundle is self-contained), got \"", value, "\""));
        }
        if (name == &value && value != decoded && !fs::is_regular_file(scene_dir / joined, ec)) continue;
        MVBRDF_ASSIGN_OR_RETURN(std::string file, BundlePath(scene_dir, "", joined.generic_string(), where));
        files->insert(std::move(file));
        break;
      }
    }
  }
  return absl::OkStatus();
}

// The mesh's files (every frame of a pattern) and what glTF ones reference.
absl::Status AddMeshFiles(const fs::path& scene_dir, const std::string& path, const scene::FrameSelection& selection,
                          int count, std::set<std::string>* files) {
  std::set<std::string> meshes;
  MVBRDF_RETURN_IF_ERROR(AddFrames(scene_dir, path, "scene.mesh.path", selection, count, &meshes));
  for (const std::string& mesh : meshes) {
    if (absl::EndsWithIgnoreCase(mesh, ".gltf")) {
      MVBRDF_RETURN_IF_ERROR(AddGltfReferences(scene_dir, mesh, "scene.mesh.path", files));
    }
  }
  files->insert(meshes.begin(), meshes.end());
  return absl::OkStatus();
}

absl::Status AddGroundTruth(const fs::path& scene_dir, std::set<std::string>* files) {
  const std::string truth_field = "ground_truth/truth.json";
  MVBRDF_ASSIGN_OR_RETURN(std::string truth_path, BundlePath(scene_dir, "", "ground_truth/truth.json", truth_field));
  v1::GroundTruth truth;
  MVBRDF_RETURN_IF_ERROR(ReadJsonFile(scene_dir / truth_path, &truth));
  files->insert(std::move(truth_path));
  for (int i = 0; i < truth.materials_size(); ++i) {
    const std::string& texture = truth.materials(i).kd_texture_path();
    if (texture.empty()) continue;
    // Relative to the truth file's folder (ground_truth.proto).
    MVBRDF_ASSIGN_OR_RETURN(
        std::string file,
        BundlePath(scene_dir, "ground_truth", texture, absl::StrCat("ground_truth.materials[", i, "].kd_texture_path")));
    files->insert(std::move(file));
  }
  return absl::OkStatus();
}

// Removes a file on destruction unless released.
class TempFile {
 public:
  explicit TempFile(fs::path path) : path_(std::move(path)) {}
  ~TempFile() {
    if (!path_.empty()) {
      std::error_code ec;
      fs::remove_all(path_, ec);
    }
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  void Release() { path_.clear(); }

 private:
  fs::path path_;
};

struct ArchiveWriteDeleter {
  void operator()(archive* a) const { archive_write_free(a); }
};
struct ArchiveReadDeleter {
  void operator()(archive* a) const { archive_read_free(a); }
};
struct EntryDeleter {
  void operator()(archive_entry* e) const { archive_entry_free(e); }
};

absl::Status WriteError(archive* a, const std::string& what) {
  return absl::InternalError(absl::StrCat("writing bundle: ", what, ": ", archive_error_string(a)));
}

absl::Status WriteEntry(archive* a, const fs::path& scene_dir, const std::string& name) {
  const fs::path file = scene_dir / name;
  std::ifstream in(file, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(file.string(), ": cannot open"));
  std::error_code ec;
  const auto size = static_cast<int64_t>(fs::file_size(file, ec));
  if (ec) return absl::InternalError(absl::StrCat(file.string(), ": ", ec.message()));

  std::unique_ptr<archive_entry, EntryDeleter> entry(archive_entry_new());
  archive_entry_set_pathname(entry.get(), name.c_str());
  archive_entry_set_filetype(entry.get(), AE_IFREG);
  archive_entry_set_perm(entry.get(), 0644);
  archive_entry_set_size(entry.get(), size);
  archive_entry_set_mtime(entry.get(), 0, 0);
  archive_entry_set_uid(entry.get(), 0);
  archive_entry_set_gid(entry.get(), 0);
  if (archive_write_header(a, entry.get()) != ARCHIVE_OK) return WriteError(a, name);

  std::vector<char> buffer(kIoBlock);
  int64_t written = 0;
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    const std::streamsize n = in.gcount();
    if (n <= 0) break;
    if (written + n > size) break;
    if (archive_write_data(a, buffer.data(), static_cast<size_t>(n)) != n) return WriteError(a, name);
    written += n;
  }
  if (in.bad() || written != size) {
    return absl::AbortedError(absl::StrCat(file.string(), ": changed while packing (", written, " of ", size,
                                           " bytes read)"));
  }
  return absl::OkStatus();
}

// ---- Unpacking -------------------------------------------------------------

// Checks an entry path: relative, '/'-separated, no empty, "." or ".."
// components, no backslashes or control characters.
absl::Status CheckEntryPath(const char* raw) {
  if (raw == nullptr || raw[0] == '\0') return absl::InvalidArgumentError("bundle entry with an empty path");
  const std::string path(raw);
  auto bad = [&](absl::string_view why) {
    return absl::InvalidArgumentError(absl::StrCat("bundle entry \"", absl::CEscape(path), "\": ", why));
  };
  if (path.size() > kMaxPathLength) return bad(absl::StrCat("path longer than ", kMaxPathLength, " bytes"));
  if (path[0] == '/') return bad("absolute path");
  for (unsigned char c : path) {
    if (c == '\\') return bad("backslash in path");
    if (c < 0x20 || c == 0x7f) return bad("control character in path");
  }
  for (absl::string_view part : absl::StrSplit(path, '/')) {
    if (part.empty()) return bad("empty path component");
    if (part == ".") return bad("\".\" path component");
    if (part == "..") return bad("\"..\" path component");
  }
  return absl::OkStatus();
}

absl::Status CheckEntryType(archive_entry* entry, const std::string& name) {
  auto bad = [&](absl::string_view what) {
    return absl::InvalidArgumentError(
        absl::StrCat("bundle entry \"", absl::CEscape(name), "\": ", what, " (only regular files are allowed)"));
  };
  if (archive_entry_hardlink(entry) != nullptr) return bad("hard link");
  if (archive_entry_symlink(entry) != nullptr) return bad("symbolic link");
  switch (archive_entry_filetype(entry)) {
    case AE_IFREG:
      return absl::OkStatus();
    case AE_IFLNK:
      return bad("symbolic link");
    case AE_IFDIR:
      return bad("directory (directories are implicit)");
    default:
      return bad("device, FIFO or socket");
  }
}

absl::Status ReadError(archive* a, const std::string& where) {
  return absl::DataLossError(absl::StrCat("bundle truncated or corrupt", where.empty() ? "" : " at entry \"",
                                          absl::CEscape(where), where.empty() ? "" : "\"", ": ",
                                          archive_error_string(a) ? archive_error_string(a) : "read error"));
}

// A tar ends with two zero blocks; libarchive accepts an archive that just
// stops at an entry boundary, so a bundle cut there would unpack as a smaller
// valid bundle. Require the end marker.
absl::Status CheckTarTrailer(const fs::path& archive_path) {
  std::error_code ec;
  const auto size = static_cast<int64_t>(fs::file_size(archive_path, ec));
  if (ec) return absl::NotFoundError(absl::StrCat(archive_path.string(), ": ", ec.message()));
  if (size < 2 * kTarBlock || size % kTarBlock != 0) {
    return absl::DataLossError(absl::StrCat("bundle truncated or corrupt: ", size,
                                            " bytes is not a whole number of 512-byte tar blocks"));
  }
  std::ifstream in(archive_path, std::ios::binary);
  in.seekg(size - 2 * kTarBlock);
  std::vector<char> tail(2 * kTarBlock);
  in.read(tail.data(), static_cast<std::streamsize>(tail.size()));
  if (!in || std::any_of(tail.begin(), tail.end(), [](char c) { return c != 0; })) {
    return absl::DataLossError("bundle truncated or corrupt: no end-of-archive marker");
  }
  return absl::OkStatus();
}

// Writes the current entry's data to `file` (created exclusively, never
// following a symlink), counting the bytes against the limits.
absl::Status ExtractData(archive* a, const fs::path& file, const std::string& name, const UnpackOptions& options,
                         int64_t* total_bytes) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("bundle entry \"", absl::CEscape(name), "\": cannot create: ", std::strerror(errno)));
  }
  std::unique_ptr<int, void (*)(int*)> closer(new int(fd), [](int* p) {
    ::close(*p);
    delete p;
  });
  int64_t entry_bytes = 0;
  for (;;) {
    const void* block = nullptr;
    size_t size = 0;
    la_int64_t offset = 0;
    const int r = archive_read_data_block(a, &block, &size, &offset);
    if (r == ARCHIVE_EOF) break;
    if (r != ARCHIVE_OK) return ReadError(a, name);
    // tar data is contiguous; a sparse entry would leave holes.
    if (offset != entry_bytes) {
      return absl::InvalidArgumentError(
          absl::StrCat("bundle entry \"", absl::CEscape(name), "\": sparse files are not allowed"));
    }
    entry_bytes += static_cast<int64_t>(size);
    *total_bytes += static_cast<int64_t>(size);
    if (entry_bytes > options.max_file_bytes) {
      return absl::ResourceExhaustedError(absl::StrCat("bundle entry \"", absl::CEscape(name),
                                                       "\": larger than max_file_bytes=", options.max_file_bytes));
    }
    if (*total_bytes > options.max_total_bytes) {
      return absl::ResourceExhaustedError(absl::StrCat("bundle exceeds max_total_bytes=", options.max_total_bytes,
                                                       " at entry \"", absl::CEscape(name), "\""));
    }
    const char* p = static_cast<const char*>(block);
    while (size > 0) {
      const ssize_t n = ::write(fd, p, size);
      if (n < 0) {
        if (errno == EINTR) continue;
        return absl::InternalError(absl::StrCat("writing ", file.string(), ": ", std::strerror(errno)));
      }
      p += n;
      size -= static_cast<size_t>(n);
    }
  }
  if (::fsync(fd) != 0) return absl::InternalError(absl::StrCat("fsync ", file.string(), ": ", std::strerror(errno)));
  return absl::OkStatus();
}

// Extracts every entry of `archive_path` into the existing empty `root`;
// returns the entry names.
absl::StatusOr<std::set<std::string>> ExtractAll(const fs::path& archive_path, const fs::path& root,
                                                 const UnpackOptions& options) {
  std::unique_ptr<archive, ArchiveReadDeleter> a(archive_read_new());
  // Uncompressed tar only (what PackBundle writes): no other formats, no
  // decompression filters.
  archive_read_support_format_tar(a.get());
  if (archive_read_open_filename(a.get(), archive_path.c_str(), kIoBlock) != ARCHIVE_OK) {
    return ReadError(a.get(), "");
  }
  const fs::path real_root = fs::canonical(root);
  std::set<std::string> names;
  int64_t total_bytes = 0;
  for (;;) {
    archive_entry* entry = nullptr;
    const int r = archive_read_next_header(a.get(), &entry);
    if (r == ARCHIVE_EOF) break;
    if (r != ARCHIVE_OK) return ReadError(a.get(), names.empty() ? "" : *names.rbegin());
    const char* raw = archive_entry_pathname(entry);
    const std::string name(raw != nullptr ? raw : "");
    MVBRDF_RETURN_IF_ERROR(CheckEntryType(entry, name));
    MVBRDF_RETURN_IF_ERROR(CheckEntryPath(raw));
    if (static_cast<int64_t>(names.size()) >= options.max_files) {
      return absl::ResourceExhaustedError(absl::StrCat("bundle has more than max_files=", options.max_files,
                                                       " entries (at entry \"", absl::CEscape(name), "\")"));
    }
    if (!names.insert(name).second) {
      return absl::InvalidArgumentError(absl::StrCat("bundle entry \"", absl::CEscape(name), "\": duplicate"));
    }
    if (archive_entry_size_is_set(entry)) {
      const int64_t size = archive_entry_size(entry);
      if (size > options.max_file_bytes) {
        return absl::ResourceExhaustedError(absl::StrCat("bundle entry \"", absl::CEscape(name), "\": ", size,
                                                         " bytes, more than max_file_bytes=", options.max_file_bytes));
      }
      if (total_bytes + size > options.max_total_bytes) {
        return absl::ResourceExhaustedError(absl::StrCat("bundle exceeds max_total_bytes=", options.max_total_bytes,
                                                         " at entry \"", absl::CEscape(name), "\""));
      }
    }
    const fs::path file = root / name;
    std::error_code ec;
    fs::create_directories(file.parent_path(), ec);
    if (ec) {
      return absl::InvalidArgumentError(
          absl::StrCat("bundle entry \"", absl::CEscape(name), "\": cannot create its folder: ", ec.message()));
    }
    // Belt and braces: the folder, resolved, must be inside the root.
    const fs::path real_parent = fs::canonical(file.parent_path(), ec);
    const fs::path inside = real_parent.lexically_relative(real_root);
    if (ec || inside.empty() || *inside.begin() == "..") {
      return absl::InvalidArgumentError(
          absl::StrCat("bundle entry \"", absl::CEscape(name), "\": resolves outside the destination"));
    }
    MVBRDF_RETURN_IF_ERROR(ExtractData(a.get(), file, name, options, &total_bytes));
  }
  return names;
}

// The scene file among the top-level entries.
absl::StatusOr<std::string> FindSceneName(const std::set<std::string>& names) {
  if (names.count("scene.json") != 0) return std::string("scene.json");
  std::vector<std::string> candidates;
  for (const std::string& name : names) {
    if (name.find('/') == std::string::npos && absl::EndsWith(name, ".json")) candidates.push_back(name);
  }
  if (candidates.size() != 1) {
    return absl::InvalidArgumentError(absl::StrCat("bundle: expected scene.json or exactly one top-level .json file, "
                                                   "found ", candidates.size()));
  }
  return candidates[0];
}

}  // namespace

absl::Status UnpackOptions::Check() const {
  if (max_files <= 0) return absl::InvalidArgumentError(absl::StrCat("max_files: must be > 0, got ", max_files));
  if (max_file_bytes < 0) {
    return absl::InvalidArgumentError(absl::StrCat("max_file_bytes: must be >= 0, got ", max_file_bytes));
  }
  if (max_total_bytes < 0) {
    return absl::InvalidArgumentError(absl::StrCat("max_total_bytes: must be >= 0, got ", max_total_bytes));
  }
  if (!expected_sha256.empty() &&
      (expected_sha256.size() != 64 ||
       !std::all_of(expected_sha256.begin(), expected_sha256.end(), [](char c) { return absl::ascii_isxdigit(c); }))) {
    return absl::InvalidArgumentError(
        absl::StrCat("expected_sha256: must be 64 hex digits, got \"", absl::CEscape(expected_sha256), "\""));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::vector<std::string>> BundleFiles(const fs::path& scene_file, const PackOptions& options) {
  MVBRDF_ASSIGN_OR_RETURN(const v1::Scene scene, scene::ReadScene(scene_file));
  MVBRDF_RETURN_IF_ERROR(scene::ValidateSceneMessage(scene));
  const fs::path scene_dir = scene_file.has_parent_path() ? scene_file.parent_path() : fs::path(".");
  const scene::FrameSelection selection = scene::SelectedFrames(scene.frames());
  const int count = scene::NumSelectedFrames(scene.frames());

  std::set<std::string> files;
  files.insert(scene_file.filename().string());
  MVBRDF_RETURN_IF_ERROR(AddMeshFiles(scene_dir, scene.mesh().path(), selection, count, &files));
  for (int i = 0; i < scene.cameras_size(); ++i) {
    const v1::Video& video = scene.cameras(i).video();
    // Its files are numbered by its own frames (Video.frame_offset).
    const scene::FrameSelection camera_frames = scene::CameraFrames(selection, video);
    MVBRDF_RETURN_IF_ERROR(AddFrames(scene_dir, video.path(), absl::StrCat("scene.cameras[", i, "].video.path"),
                                     camera_frames, count, &files));
    if (!video.mask_path().empty()) {
      MVBRDF_RETURN_IF_ERROR(AddFrames(scene_dir, video.mask_path(), absl::StrCat("scene.cameras[", i, "].video.mask_path"),
                                       camera_frames, count, &files));
    }
  }
  if (!scene.segmentation_path().empty()) {
    MVBRDF_ASSIGN_OR_RETURN(std::string file,
                            BundlePath(scene_dir, "", scene.segmentation_path(), "scene.segmentation_path"));
    files.insert(std::move(file));
  }
  std::error_code ec;
  if (options.include_ground_truth && fs::is_directory(scene_dir / "ground_truth", ec)) {
    MVBRDF_RETURN_IF_ERROR(AddGroundTruth(scene_dir, &files));
  }
  return std::vector<std::string>(files.begin(), files.end());
}

absl::StatusOr<BundleInfo> PackBundle(const fs::path& scene_file, const fs::path& archive_path,
                                      const PackOptions& options) {
  MVBRDF_ASSIGN_OR_RETURN(const std::vector<std::string> files, BundleFiles(scene_file, options));
  const fs::path scene_dir = scene_file.has_parent_path() ? scene_file.parent_path() : fs::path(".");

  const fs::path out_dir = archive_path.has_parent_path() ? archive_path.parent_path() : fs::path(".");
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) return absl::InternalError(absl::StrCat(out_dir.string(), ": cannot create: ", ec.message()));
  std::string temp_name = (out_dir / (archive_path.filename().string() + ".tmp-XXXXXX")).string();
  const int fd = ::mkstemp(temp_name.data());
  if (fd < 0) return absl::InternalError(absl::StrCat(temp_name, ": cannot create: ", std::strerror(errno)));
  TempFile temp(temp_name);
  std::unique_ptr<int, void (*)(int*)> closer(new int(fd), [](int* p) {
    ::close(*p);
    delete p;
  });

  {
    std::unique_ptr<archive, ArchiveWriteDeleter> a(archive_write_new());
    // ustar, with pax extended headers only where ustar cannot say it (long
    // paths, huge files): deterministic for the same input.
    if (archive_write_set_format_pax_restricted(a.get()) != ARCHIVE_OK ||
        archive_write_add_filter_none(a.get()) != ARCHIVE_OK || archive_write_open_fd(a.get(), fd) != ARCHIVE_OK) {
      return WriteError(a.get(), temp_name);
    }
    for (const std::string& name : files) MVBRDF_RETURN_IF_ERROR(WriteEntry(a.get(), scene_dir, name));
    if (archive_write_close(a.get()) != ARCHIVE_OK) return WriteError(a.get(), temp_name);
  }
  if (::fsync(fd) != 0) return absl::InternalError(absl::StrCat(temp_name, ": fsync: ", std::strerror(errno)));
  closer.reset();
  ::chmod(temp_name.c_str(), 0644);  // mkstemp creates 0600

  BundleInfo info;
  MVBRDF_ASSIGN_OR_RETURN(info.sha256, Sha256File(temp_name));
  info.size = static_cast<int64_t>(fs::file_size(temp_name, ec));
  info.num_files = static_cast<int>(files.size());
  info.scene_name = scene_file.filename().string();
  fs::rename(temp_name, archive_path, ec);
  if (ec) return absl::InternalError(absl::StrCat("renaming to ", archive_path.string(), ": ", ec.message()));
  temp.Release();
  return info;
}

absl::StatusOr<fs::path> UnpackBundle(const fs::path& archive_path, const fs::path& dest_dir,
                                      const UnpackOptions& options) {
  MVBRDF_RETURN_IF_ERROR(options.Check());
  std::error_code ec;
  if (!fs::is_regular_file(archive_path, ec)) {
    return absl::NotFoundError(absl::StrCat(archive_path.string(), ": bundle not found"));
  }
  if (!options.expected_sha256.empty()) {
    MVBRDF_ASSIGN_OR_RETURN(const std::string actual, Sha256File(archive_path));
    const std::string expected = absl::AsciiStrToLower(options.expected_sha256);
    if (actual != expected) {
      return absl::InvalidArgumentError(absl::StrCat("bundle hash mismatch: expected ", expected, ", got ", actual));
    }
  }
  MVBRDF_RETURN_IF_ERROR(CheckTarTrailer(archive_path));

  if (fs::exists(fs::symlink_status(dest_dir, ec))) {
    if (!fs::is_directory(fs::symlink_status(dest_dir, ec)) || !fs::is_empty(dest_dir, ec)) {
      return absl::AlreadyExistsError(
          absl::StrCat(dest_dir.string(), ": exists and is not an empty directory (bundle destination)"));
    }
  }
  const fs::path parent = dest_dir.has_parent_path() ? dest_dir.parent_path() : fs::path(".");
  fs::create_directories(parent, ec);
  if (ec) return absl::InternalError(absl::StrCat(parent.string(), ": cannot create: ", ec.message()));
  std::string temp_name = (parent / (dest_dir.filename().string() + ".unpack-XXXXXX")).string();
  if (::mkdtemp(temp_name.data()) == nullptr) {
    return absl::InternalError(absl::StrCat(temp_name, ": cannot create: ", std::strerror(errno)));
  }
  TempFile temp(temp_name);
  ::chmod(temp_name.c_str(), 0755);  // mkdtemp creates 0700

  MVBRDF_ASSIGN_OR_RETURN(const std::set<std::string> names, ExtractAll(archive_path, temp_name, options));
  MVBRDF_ASSIGN_OR_RETURN(const std::string scene_name, FindSceneName(names));
  // Replaces an empty dest_dir atomically (rename(2)).
  fs::rename(temp_name, dest_dir, ec);
  if (ec) return absl::InternalError(absl::StrCat("renaming to ", dest_dir.string(), ": ", ec.message()));
  temp.Release();
  return dest_dir / scene_name;
}

absl::Status CheckScenePath(absl::string_view scene_path) {
  if (scene_path.empty()) return absl::OkStatus();
  const fs::path relative{std::string(scene_path)};
  bool parent = false;
  for (const fs::path& part : relative) parent = parent || part == "..";
  if (relative.is_absolute() || parent || relative.lexically_normal() != relative) {
    return absl::InvalidArgumentError(absl::StrCat(
        "scene_path: must be a relative, normalised path inside the bundle without \"..\", got \"", scene_path, "\""));
  }
  return absl::OkStatus();
}

absl::StatusOr<fs::path> SceneFileIn(const fs::path& dir, absl::string_view scene_path) {
  if (absl::Status checked = CheckScenePath(scene_path); !checked.ok()) return checked;
  if (!scene_path.empty()) {
    const fs::path file = dir / std::string(scene_path);
    if (!fs::is_regular_file(file)) {
      return absl::InvalidArgumentError(absl::StrCat("scene_path: the bundle has no file \"", scene_path, "\""));
    }
    return file;
  }
  if (fs::is_regular_file(dir / "scene.json")) return dir / "scene.json";
  std::vector<fs::path> found;
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    if (e.is_regular_file() && e.path().extension() == ".json") found.push_back(e.path());
  }
  if (ec) return absl::InternalError(absl::StrCat(dir.string(), ": ", ec.message()));
  if (found.size() != 1) {
    return absl::InvalidArgumentError(
        "scene_path: the bundle has no scene.json and not exactly one top-level .json file; name the scene file");
  }
  return found[0];
}

}  // namespace mvbrdf::bundle
