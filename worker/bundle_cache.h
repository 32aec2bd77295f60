// A worker's local cache of sequence bundles: each bundle is downloaded once
// (verified against its SHA-256), unpacked strictly into
// <dir>/<sha256>/ and reused by every later task on it, across jobs and
// worker restarts. The scene loaded from it is kept too (the last one), so a
// worker running a sweep's tasks loads its sequence once.
//
// Threading: not thread-safe; the worker serialises its tasks' calls.
#ifndef MVBRDF_WORKER_BUNDLE_CACHE_H_
#define MVBRDF_WORKER_BUNDLE_CACHE_H_

#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/scene/sequence.h"

namespace mvbrdf::worker {

class BundleCache {
 public:
  // Writes bundle `sha256` to the file `dest` (the cache verifies it).
  using Fetch = std::function<absl::Status(const std::string& sha256, const std::filesystem::path& dest)>;

  // `unpacked_elsewhere` (may be empty): a directory whose <sha256>/
  // subdirectories are bundles a server on this machine verified and
  // unpacked (WorkerOptions::server_unpacked_bundles); such a bundle is read
  // where it is, neither fetched nor unpacked here.
  BundleCache(std::filesystem::path dir, Fetch fetch, std::filesystem::path unpacked_elsewhere = {})
      : dir_(std::move(dir)), fetch_(std::move(fetch)), unpacked_elsewhere_(std::move(unpacked_elsewhere)) {}

  // The sequence of bundle `sha256` with its scene file at `scene_path`
  // inside the bundle (empty: the bundle's default, see bundle::UnpackBundle).
  // INVALID_ARGUMENT naming scene_path for a path leaving the bundle, or when
  // the download does not match its hash.
  absl::StatusOr<std::shared_ptr<const scene::Sequence>> Sequence(const std::string& sha256,
                                                                  const std::string& scene_path);

  int downloads() const { return downloads_; }

 private:
  absl::StatusOr<std::filesystem::path> Unpacked(const std::string& sha256);

  const std::filesystem::path dir_;
  const Fetch fetch_;
  const std::filesystem::path unpacked_elsewhere_;
  int downloads_ = 0;
  std::string loaded_key_;
  std::shared_ptr<const scene::Sequence> loaded_;
};

}  // namespace mvbrdf::worker

#endif  // MVBRDF_WORKER_BUNDLE_CACHE_H_
