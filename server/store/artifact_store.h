// Content-addressed artifacts (issue #5): atlases, tables, images and
// uploaded sequence bundles, stored once per content under a data directory
// as <dir>/<sha[0:2]>/<sha>, indexed in the artifacts table by (job, name).
//
// A file is written to a temporary file in <dir>/tmp and renamed into place,
// so a reader never sees a half-written artifact. Identical content is stored
// once however many jobs or names refer to it. Reads verify the hash, so a
// damaged file is reported (DATA_LOSS), never served. Paths come only from a
// validated hex digest; job ids and names are index data, never path parts.
//
// Threading: every method may be called from any thread (a mutex serialises
// the index; files are renamed atomically, so several stores on one data
// directory are safe too).
#ifndef MVBRDF_SERVER_STORE_ARTIFACT_STORE_H_
#define MVBRDF_SERVER_STORE_ARTIFACT_STORE_H_

#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/store/sqlite_db.h"

namespace mvbrdf::store {

struct Artifact {
  std::string job_id;  // empty for uploads that belong to no job
  std::string name;    // e.g. "atlas/kd.exr"
  std::string sha256;  // 64 hex digits
  int64_t size = 0;    // bytes
  int64_t created_ms = 0;
};

class ArtifactStore {
 public:
  // `db_path`: the SQLite file (shared with the other stores); `data_dir`:
  // where the files go (created when missing).
  static absl::StatusOr<std::unique_ptr<ArtifactStore>> Open(const std::filesystem::path& db_path,
                                                             const std::filesystem::path& data_dir);

  // Stores `bytes` (once per content) and indexes it as (job_id, name),
  // replacing an earlier artifact of that name.
  absl::StatusOr<Artifact> PutBytes(absl::string_view job_id, absl::string_view name, absl::string_view bytes,
                                    int64_t now_ms);
  // The same for the contents of the file at `source` (streamed; the source
  // is copied, not moved).
  absl::StatusOr<Artifact> PutFile(absl::string_view job_id, absl::string_view name,
                                   const std::filesystem::path& source, int64_t now_ms);

  // The verified contents. INVALID_ARGUMENT for a malformed digest,
  // NOT_FOUND when not indexed or the file is missing, DATA_LOSS when the
  // file does not hash to `sha256`.
  absl::StatusOr<std::string> Read(absl::string_view sha256);
  // The path of the verified file, for streaming it out in chunks. The
  // file is immutable once stored.
  absl::StatusOr<std::filesystem::path> OpenVerified(absl::string_view sha256);

  // The job's artifacts by name.
  absl::StatusOr<std::vector<Artifact>> ArtifactsOfJob(absl::string_view job_id);

  const std::filesystem::path& data_dir() const { return data_dir_; }
  // Where the content `sha256` lives (it need not exist). INVALID_ARGUMENT
  // unless `sha256` is 64 lowercase hex digits.
  absl::StatusOr<std::filesystem::path> PathOf(absl::string_view sha256) const;

 private:
  ArtifactStore(std::unique_ptr<SqliteDb> db, std::filesystem::path data_dir)
      : db_(std::move(db)), data_dir_(std::move(data_dir)) {}

  // Moves the finished temporary file into place (or drops it when the
  // content is already there) and indexes it.
  absl::StatusOr<Artifact> Commit(absl::string_view job_id, absl::string_view name,
                                  const std::filesystem::path& temp, const std::string& sha256, int64_t size,
                                  int64_t now_ms);
  absl::Status CheckIndexed(absl::string_view sha256);

  std::mutex mu_;
  std::unique_ptr<SqliteDb> db_;  // guarded by mu_
  const std::filesystem::path data_dir_;
};

}  // namespace mvbrdf::store

#endif  // MVBRDF_SERVER_STORE_ARTIFACT_STORE_H_
