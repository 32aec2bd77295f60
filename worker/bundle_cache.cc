#include "worker/bundle_cache.h"

#include <system_error>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/bundle/bundle.h"
#include "worker/worker_fault.h"

namespace mvbrdf::worker {
namespace fs = std::filesystem;

namespace {

bool IsDigest(const std::string& s) {
  if (s.size() != 64) return false;
  for (char c : s) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

}  // namespace

absl::StatusOr<fs::path> BundleCache::Unpacked(const std::string& sha256) {
  if (!IsDigest(sha256)) {
    return absl::InvalidArgumentError(absl::StrCat("bundle_sha256: expected 64 lowercase hex digits, got \"", sha256, "\""));
  }
  if (!unpacked_elsewhere_.empty()) {
    // The server renames a bundle's directory into place only once it is
    // unpacked whole (BundleArea::UnpackedScene): one that exists is complete.
    std::error_code ec;
    const fs::path there = unpacked_elsewhere_ / sha256;
    if (fs::is_directory(there, ec)) return there;
  }
  const fs::path dir = dir_ / sha256;
  const fs::path done = dir_ / (sha256 + ".ok");
  if (fs::exists(done) && fs::is_directory(dir)) return dir;
  std::error_code ec;
  fs::create_directories(dir_, ec);
  // This worker's disk: not the job's fault (UNAVAILABLE, retried elsewhere).
  if (ec) return WorkerFault(absl::UnavailableError(absl::StrCat(dir_.string(), ": cannot create: ", ec.message())));
  const fs::path archive = dir_ / (sha256 + ".tar");
  MVBRDF_RETURN_IF_ERROR(fetch_(sha256, archive));
  ++downloads_;
  fs::remove_all(dir, ec);
  bundle::UnpackOptions unpack;  // checks the hash before extracting
  unpack.expected_sha256 = sha256;
  absl::StatusOr<fs::path> scene = bundle::UnpackBundle(archive, dir, unpack);
  fs::remove(archive, ec);
  // Writing the files (INTERNAL, naming them) is this worker's disk; a
  // bundle that does not unpack (hash, entries) is the job's.
  if (!scene.ok() && scene.status().code() == absl::StatusCode::kInternal) return WorkerFault(scene.status());
  if (!scene.ok()) return scene.status();
  // The marker last: a crash before it leaves a directory that is unpacked again.
  if (FILE* f = std::fopen(done.c_str(), "w"); f != nullptr) std::fclose(f);
  return dir;
}

absl::StatusOr<std::shared_ptr<const scene::Sequence>> BundleCache::Sequence(const std::string& sha256,
                                                                             const std::string& scene_path) {
  const std::string key = sha256 + "/" + scene_path;
  if (loaded_ != nullptr && loaded_key_ == key) return loaded_;
  if (absl::Status checked = bundle::CheckScenePath(scene_path); !checked.ok()) return checked;
  MVBRDF_ASSIGN_OR_RETURN(const fs::path dir, Unpacked(sha256));
  MVBRDF_ASSIGN_OR_RETURN(const fs::path scene_file, bundle::SceneFileIn(dir, scene_path));
  scene::LoadOptions load;
  load.check_all_frames = false;  // each frame is checked when it is read
  MVBRDF_ASSIGN_OR_RETURN(scene::Sequence sequence, scene::LoadSequence(scene_file, load));
  loaded_ = std::make_shared<const scene::Sequence>(std::move(sequence));
  loaded_key_ = key;
  return loaded_;
}

}  // namespace mvbrdf::worker
