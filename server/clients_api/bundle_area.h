// Where the server keeps sequence bundles (issue #5), under its data dir:
//   bundles/<sha256>.tar    complete bundles whose hash was verified
//   uploads/<sha256>.part   partial uploads (resumable: the bytes so far)
//   scenes/<sha256>/        a complete bundle unpacked once, for validation
// Paths are built only from validated digests (64 lowercase hex digits).
//
// Threading: every method may be called from any thread. Appending to a
// .part file is not guarded here: the caller claims the upload (Claim) so
// that one upload of a digest runs at a time.
#ifndef MVBRDF_SERVER_CLIENTS_API_BUNDLE_AREA_H_
#define MVBRDF_SERVER_CLIENTS_API_BUNDLE_AREA_H_

#include <cstdint>
#include <filesystem>
#include <mutex>
#include <set>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace mvbrdf::clients_api {

struct UploadProgress {
  int64_t received_bytes = 0;
  bool complete = false;  // bundles/<sha>.tar exists (hash verified)
};

class BundleArea {
 public:
  explicit BundleArea(std::filesystem::path data_dir) : data_dir_(std::move(data_dir)) {}

  // INVALID_ARGUMENT naming `field` unless `sha256` is 64 lowercase hex digits.
  static absl::Status CheckDigest(absl::string_view field, absl::string_view sha256);

  std::filesystem::path BundlePath(absl::string_view sha256) const;
  std::filesystem::path PartPath(absl::string_view sha256) const;
  std::filesystem::path SceneDir(absl::string_view sha256) const;
  // Where SceneDir's directories lie (scenes/): a worker on this machine can
  // read a bundle there (WorkerOptions::server_unpacked_bundles).
  std::filesystem::path ScenesDir() const;

  // How far the upload of `sha256` (a validated digest) got.
  absl::StatusOr<UploadProgress> Progress(absl::string_view sha256) const;

  // One upload of a digest at a time: false when another holds it. Release
  // when the upload ends.
  bool Claim(const std::string& sha256);
  void Release(const std::string& sha256);

  // Appends `bytes` to the .part file, which must hold exactly `offset`
  // bytes (the caller checked it against Progress).
  absl::Status Append(absl::string_view sha256, int64_t offset, absl::string_view bytes);
  // The .part is complete: verifies its SHA-256 and renames it to the
  // bundle. On a mismatch the .part is deleted and INVALID_ARGUMENT says
  // "upload hash does not match".
  absl::Status Commit(absl::string_view sha256);
  // Drops a partial upload (e.g. one declared with the wrong size).
  void Discard(absl::string_view sha256);

  // The scene file of the complete bundle `sha256`, unpacked once into
  // scenes/<sha256>/ (strict UnpackBundle with the digest checked and at most
  // `max_bytes` of contents); later calls reuse the unpacked copy.
  // `scene_path`: the scene file inside the bundle, empty for the default
  // ("scene.json", else the only top-level .json), relative and normalised
  // (INVALID_ARGUMENT naming `scene_path` otherwise).
  absl::StatusOr<std::filesystem::path> UnpackedScene(absl::string_view sha256, absl::string_view scene_path,
                                                      int64_t max_bytes);

 private:
  absl::Status EnsureDirs() const;

  const std::filesystem::path data_dir_;
  std::mutex mu_;
  std::set<std::string> uploading_;  // guarded by mu_
  std::mutex unpack_mu_;             // one unpack at a time (same digest twice)
};

}  // namespace mvbrdf::clients_api

#endif  // MVBRDF_SERVER_CLIENTS_API_BUNDLE_AREA_H_
