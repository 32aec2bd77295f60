#include "server/clients_api/bundle_area.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <fstream>
#include <system_error>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/bundle/bundle.h"
#include "core/bundle/sha256.h"
#include "server/store/digest.h"

namespace mvbrdf::clients_api {
namespace fs = std::filesystem;

absl::Status BundleArea::CheckDigest(absl::string_view field, absl::string_view sha256) {
  if (store::IsSha256Hex(sha256)) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(field, ": must be 64 lowercase hex digits (a SHA-256), got \"", sha256.substr(0, 80), "\""));
}

fs::path BundleArea::BundlePath(absl::string_view sha256) const {
  return data_dir_ / "bundles" / absl::StrCat(sha256, ".tar");
}
fs::path BundleArea::PartPath(absl::string_view sha256) const {
  return data_dir_ / "uploads" / absl::StrCat(sha256, ".part");
}
fs::path BundleArea::ScenesDir() const { return data_dir_ / "scenes"; }
fs::path BundleArea::SceneDir(absl::string_view sha256) const { return ScenesDir() / std::string(sha256); }

absl::Status BundleArea::EnsureDirs() const {
  for (const char* sub : {"bundles", "uploads", "scenes"}) {
    std::error_code ec;
    fs::create_directories(data_dir_ / sub, ec);
    if (ec) return absl::InternalError(absl::StrCat((data_dir_ / sub).string(), ": ", ec.message()));
  }
  return absl::OkStatus();
}

absl::StatusOr<UploadProgress> BundleArea::Progress(absl::string_view sha256) const {
  UploadProgress progress;
  for (const auto& [path, complete] : {std::pair{BundlePath(sha256), true}, std::pair{PartPath(sha256), false}}) {
    std::error_code ec;
    const auto size = fs::file_size(path, ec);
    if (ec == std::errc::no_such_file_or_directory) continue;
    if (ec) return absl::InternalError(absl::StrCat(path.string(), ": ", ec.message()));
    progress.received_bytes = static_cast<int64_t>(size);
    progress.complete = complete;
    return progress;
  }
  return progress;
}

bool BundleArea::Claim(const std::string& sha256) {
  std::lock_guard<std::mutex> lock(mu_);
  return uploading_.insert(sha256).second;
}

void BundleArea::Release(const std::string& sha256) {
  std::lock_guard<std::mutex> lock(mu_);
  uploading_.erase(sha256);
}

absl::Status BundleArea::Append(absl::string_view sha256, int64_t offset, absl::string_view bytes) {
  if (absl::Status dirs = EnsureDirs(); !dirs.ok()) return dirs;
  const fs::path part = PartPath(sha256);
  std::error_code ec;
  if (offset == 0) fs::remove(part, ec);  // a fresh start: no stale bytes
  // POSIX I/O so that the reason reaches the uploader: a full disk is
  // RESOURCE_EXHAUSTED with "No space left on device", not a bare failure.
  // Bytes written before a failure stay: they are a valid prefix, and the
  // upload resumes after them (QueryUpload).
  const std::string name = absl::StrCat("uploads/", part.filename().string());  // no server path in errors
  const int fd = ::open(part.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0) return ErrnoStatus(errno, "cannot open", name);
  absl::Status written = WriteAllToFd(fd, bytes, name);
  if (::close(fd) != 0 && written.ok()) written = ErrnoStatus(errno, "write failed", name);
  return written;
}

absl::Status BundleArea::Commit(absl::string_view sha256) {
  const fs::path part = PartPath(sha256);
  absl::StatusOr<std::string> actual = bundle::Sha256File(part);
  if (!actual.ok()) return actual.status();
  if (*actual != sha256) {
    Discard(sha256);
    return absl::InvalidArgumentError(
        absl::StrCat("upload hash does not match: sha256 says ", sha256, ", the bytes hash to ", *actual));
  }
  std::error_code ec;
  fs::rename(part, BundlePath(sha256), ec);
  if (ec) return absl::InternalError(absl::StrCat(BundlePath(sha256).string(), ": ", ec.message()));
  return absl::OkStatus();
}

void BundleArea::Discard(absl::string_view sha256) {
  std::error_code ignored;
  fs::remove(PartPath(sha256), ignored);
}

absl::StatusOr<fs::path> BundleArea::UnpackedScene(absl::string_view sha256, absl::string_view scene_path,
                                                   int64_t max_bytes) {
  if (absl::Status checked = bundle::CheckScenePath(scene_path); !checked.ok()) return checked;
  if (absl::Status dirs = EnsureDirs(); !dirs.ok()) return dirs;
  const fs::path dir = SceneDir(sha256);
  {
    // UnpackBundle renames into place only on success, so an existing
    // directory is a complete copy.
    std::lock_guard<std::mutex> lock(unpack_mu_);
    if (!fs::is_directory(dir)) {
      bundle::UnpackOptions options;
      options.expected_sha256 = std::string(sha256);
      options.max_file_bytes = max_bytes;
      options.max_total_bytes = max_bytes;
      absl::StatusOr<fs::path> unpacked = bundle::UnpackBundle(BundlePath(sha256), dir, options);
      if (!unpacked.ok()) return unpacked.status();
    }
  }
  return bundle::SceneFileIn(dir, scene_path);
}

}  // namespace mvbrdf::clients_api
