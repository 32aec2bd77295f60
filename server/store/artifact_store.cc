#include "server/store/artifact_store.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <system_error>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"
#include "server/store/digest.h"
#include "server/store/schema.h"

namespace mvbrdf::store {
namespace {

constexpr size_t kChunkBytes = size_t{1} << 20;

absl::Status ErrnoError(absl::string_view what, const std::filesystem::path& path) {
  return ErrnoStatus(errno, what, path.string());
}

// A file written through a POSIX descriptor so that it can be fsync'ed before
// the rename (the rename must not outlive the data in a crash).
class TempFile {
 public:
  static absl::StatusOr<TempFile> Create(const std::filesystem::path& dir) {
    MVBRDF_ASSIGN_OR_RETURN(std::string id, RandomId128());
    std::filesystem::path path = dir / absl::StrCat("put-", id);
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) return ErrnoError("cannot create temporary file", path);
    return TempFile(std::move(path), fd);
  }

  TempFile(TempFile&& other) noexcept : path_(std::move(other.path_)), fd_(std::exchange(other.fd_, -1)) {
    other.path_.clear();
  }
  TempFile& operator=(TempFile&&) = delete;
  ~TempFile() {
    if (fd_ >= 0) ::close(fd_);
    if (!path_.empty()) {
      std::error_code ignored;  // best effort: a leftover in tmp/ is harmless
      std::filesystem::remove(path_, ignored);
    }
  }

  absl::Status Write(absl::string_view bytes) { return WriteAllToFd(fd_, bytes, path_.string()); }

  // fsync and close; the file stays until Release() or destruction.
  absl::Status Finish() {
    if (::fsync(fd_) != 0) return ErrnoError("fsync failed", path_);
    const int fd = std::exchange(fd_, -1);
    if (::close(fd) != 0) return ErrnoError("close failed", path_);
    return absl::OkStatus();
  }

  const std::filesystem::path& path() const { return path_; }
  // The caller took the file (renamed it): do not remove it.
  void Release() { path_.clear(); }

 private:
  TempFile(std::filesystem::path path, int fd) : path_(std::move(path)), fd_(fd) {}

  std::filesystem::path path_;
  int fd_;
};

absl::StatusOr<std::string> HashFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(path.string(), ": cannot open artifact file"));
  Sha256 sha;
  std::string chunk(kChunkBytes, '\0');
  while (in) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    sha.Update(absl::string_view(chunk.data(), static_cast<size_t>(in.gcount())));
  }
  if (in.bad()) return absl::DataLossError(absl::StrCat(path.string(), ": read failed"));
  return sha.FinishHex();
}

}  // namespace

absl::StatusOr<std::unique_ptr<ArtifactStore>> ArtifactStore::Open(const std::filesystem::path& db_path,
                                                                   const std::filesystem::path& data_dir) {
  std::error_code ec;
  std::filesystem::create_directories(data_dir / "tmp", ec);
  if (ec) {
    return absl::PermissionDeniedError(
        absl::StrCat(data_dir.string(), ": cannot create the artifact directory: ", ec.message()));
  }
  MVBRDF_ASSIGN_OR_RETURN(std::unique_ptr<SqliteDb> db, OpenStoreDb(db_path));
  return std::unique_ptr<ArtifactStore>(new ArtifactStore(std::move(db), data_dir));
}

absl::StatusOr<std::filesystem::path> ArtifactStore::PathOf(absl::string_view sha256) const {
  if (!IsSha256Hex(sha256)) {
    return absl::InvalidArgumentError(
        absl::StrCat("artifact digest '", sha256, "': expected 64 lowercase hex digits (SHA-256)"));
  }
  return data_dir_ / std::string(sha256.substr(0, 2)) / std::string(sha256);
}

absl::StatusOr<Artifact> ArtifactStore::PutBytes(absl::string_view job_id, absl::string_view name,
                                                 absl::string_view bytes, int64_t now_ms) {
  MVBRDF_ASSIGN_OR_RETURN(TempFile temp, TempFile::Create(data_dir_ / "tmp"));
  MVBRDF_RETURN_IF_ERROR(temp.Write(bytes));
  MVBRDF_RETURN_IF_ERROR(temp.Finish());
  MVBRDF_ASSIGN_OR_RETURN(Artifact artifact, Commit(job_id, name, temp.path(), Sha256Hex(bytes),
                                                    static_cast<int64_t>(bytes.size()), now_ms));
  temp.Release();  // Commit renamed or removed it
  return artifact;
}

absl::StatusOr<Artifact> ArtifactStore::PutFile(absl::string_view job_id, absl::string_view name,
                                                const std::filesystem::path& source, int64_t now_ms) {
  std::ifstream in(source, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(source.string(), ": cannot open the artifact to store"));
  MVBRDF_ASSIGN_OR_RETURN(TempFile temp, TempFile::Create(data_dir_ / "tmp"));
  Sha256 sha;
  int64_t size = 0;
  std::string chunk(kChunkBytes, '\0');
  while (in) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    const absl::string_view piece(chunk.data(), static_cast<size_t>(in.gcount()));
    sha.Update(piece);
    MVBRDF_RETURN_IF_ERROR(temp.Write(piece));
    size += static_cast<int64_t>(piece.size());
  }
  if (in.bad()) return absl::DataLossError(absl::StrCat(source.string(), ": read failed"));
  MVBRDF_RETURN_IF_ERROR(temp.Finish());
  MVBRDF_ASSIGN_OR_RETURN(Artifact artifact, Commit(job_id, name, temp.path(), sha.FinishHex(), size, now_ms));
  temp.Release();
  return artifact;
}

absl::StatusOr<Artifact> ArtifactStore::Commit(absl::string_view job_id, absl::string_view name,
                                               const std::filesystem::path& temp, const std::string& sha256,
                                               int64_t size, int64_t now_ms) {
  MVBRDF_ASSIGN_OR_RETURN(std::filesystem::path final_path, PathOf(sha256));
  std::error_code ec;
  std::filesystem::create_directories(final_path.parent_path(), ec);
  if (ec) {
    return absl::PermissionDeniedError(
        absl::StrCat(final_path.parent_path().string(), ": cannot create directory: ", ec.message()));
  }
  bool keep_existing = false;
  if (std::filesystem::exists(final_path, ec)) {
    // Dedup, unless the stored copy was damaged: then the new one replaces it.
    absl::StatusOr<std::string> existing = HashFile(final_path);
    keep_existing = existing.ok() && *existing == sha256;
  }
  if (keep_existing) {
    std::filesystem::remove(temp, ec);
  } else {
    // rename(2) replaces atomically: readers see the old file or the new one.
    std::filesystem::rename(temp, final_path, ec);
    if (ec) {
      std::error_code ignored;
      std::filesystem::remove(temp, ignored);
      return absl::InternalError(absl::StrCat(final_path.string(), ": cannot rename into place: ", ec.message()));
    }
  }

  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(
      Statement insert,
      Statement::Prepare(*db_,
                         "INSERT OR REPLACE INTO artifacts (job_id, name, sha256, size, created_ms) "
                         "VALUES (?1, ?2, ?3, ?4, ?5)"));
  MVBRDF_RETURN_IF_ERROR(insert.BindText(1, job_id));
  MVBRDF_RETURN_IF_ERROR(insert.BindText(2, name));
  MVBRDF_RETURN_IF_ERROR(insert.BindText(3, sha256));
  MVBRDF_RETURN_IF_ERROR(insert.BindInt64(4, size));
  MVBRDF_RETURN_IF_ERROR(insert.BindInt64(5, now_ms));
  MVBRDF_RETURN_IF_ERROR(insert.Run());
  return Artifact{std::string(job_id), std::string(name), sha256, size, now_ms};
}

absl::Status ArtifactStore::CheckIndexed(absl::string_view sha256) {
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(Statement select,
                          Statement::Prepare(*db_, "SELECT 1 FROM artifacts WHERE sha256 = ?1 LIMIT 1"));
  MVBRDF_RETURN_IF_ERROR(select.BindText(1, sha256));
  MVBRDF_ASSIGN_OR_RETURN(StepResult step, select.Step());
  if (step == StepResult::kDone) return absl::NotFoundError(absl::StrCat("artifact ", sha256, ": not stored"));
  return absl::OkStatus();
}

absl::StatusOr<std::filesystem::path> ArtifactStore::OpenVerified(absl::string_view sha256) {
  MVBRDF_ASSIGN_OR_RETURN(std::filesystem::path path, PathOf(sha256));
  MVBRDF_RETURN_IF_ERROR(CheckIndexed(sha256));
  MVBRDF_ASSIGN_OR_RETURN(std::string actual, HashFile(path));
  if (actual != sha256) {
    return absl::DataLossError(absl::StrCat("artifact ", sha256, ": file ", path.string(), " hashes to ", actual,
                                            " (damaged on disk)"));
  }
  return path;
}

absl::StatusOr<std::string> ArtifactStore::Read(absl::string_view sha256) {
  MVBRDF_ASSIGN_OR_RETURN(std::filesystem::path path, PathOf(sha256));
  MVBRDF_RETURN_IF_ERROR(CheckIndexed(sha256));
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat("artifact ", sha256, ": file ", path.string(), " is missing"));
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) return absl::DataLossError(absl::StrCat(path.string(), ": read failed"));
  const std::string actual = Sha256Hex(bytes);
  if (actual != sha256) {
    return absl::DataLossError(absl::StrCat("artifact ", sha256, ": file ", path.string(), " hashes to ", actual,
                                            " (damaged on disk)"));
  }
  return bytes;
}

absl::StatusOr<std::vector<Artifact>> ArtifactStore::ArtifactsOfJob(absl::string_view job_id) {
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(
      Statement select,
      Statement::Prepare(*db_,
                         "SELECT job_id, name, sha256, size, created_ms FROM artifacts WHERE job_id = ?1 "
                         "ORDER BY name"));
  MVBRDF_RETURN_IF_ERROR(select.BindText(1, job_id));
  std::vector<Artifact> artifacts;
  MVBRDF_RETURN_IF_ERROR(select.ForEachRow([&]() -> absl::Status {
    artifacts.push_back(Artifact{select.ColumnText(0), select.ColumnText(1), select.ColumnText(2),
                                 select.ColumnInt64(3), select.ColumnInt64(4)});
    return absl::OkStatus();
  }));
  return artifacts;
}

}  // namespace mvbrdf::store
