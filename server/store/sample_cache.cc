#include "server/store/sample_cache.h"

#include <zlib.h>

#include <algorithm>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "server/store/digest.h"
#include "server/store/schema.h"
#include "server/store/zlib_compress.h"

namespace mvbrdf::store {
namespace {

constexpr const char* kKeyWhere =
    "sequence_hash = ?1 AND configuration = ?2 AND sample_level = ?3 AND options_hash = ?4";

absl::Status BindKey(Statement& statement, const SampleKey& key) {
  MVBRDF_RETURN_IF_ERROR(statement.BindText(1, key.sequence_hash));
  MVBRDF_RETURN_IF_ERROR(statement.BindText(2, key.configuration));
  MVBRDF_RETURN_IF_ERROR(statement.BindInt64(3, key.sample_level));
  return statement.BindText(4, key.options_hash);
}

// Empty error string on success.
std::string Uncompress(absl::string_view stored, size_t raw_size, std::string* out) {
  out->assign(raw_size, '\0');
  uLongf size = static_cast<uLongf>(raw_size);
  // zlib wants a non-null destination even for 0 bytes.
  char dummy = 0;
  Bytef* dest = raw_size == 0 ? reinterpret_cast<Bytef*>(&dummy) : reinterpret_cast<Bytef*>(out->data());
  const int code = uncompress(dest, &size, reinterpret_cast<const Bytef*>(stored.data()),
                              static_cast<uLong>(stored.size()));
  if (code != Z_OK) return absl::StrCat("zlib uncompress failed with code ", code);
  if (size != raw_size) return absl::StrCat("uncompressed to ", size, " bytes, expected ", raw_size);
  return std::string();
}

}  // namespace

std::string SampleKey::ToString() const {
  return absl::StrCat(sequence_hash, "/", configuration, "/", sample_level, "/", options_hash);
}

absl::Status SampleCacheOptions::Check() const {
  if (max_stored_bytes < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("SampleCacheOptions.max_stored_bytes: must be >= 0, got ", max_stored_bytes));
  }
  if (compression_level < 1 || compression_level > 9) {
    return absl::InvalidArgumentError(
        absl::StrCat("SampleCacheOptions.compression_level: must be in [1, 9], got ", compression_level));
  }
  if (memory_bytes < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("SampleCacheOptions.memory_bytes: must be >= 0, got ", memory_bytes));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<SampleCache>> SampleCache::Open(const std::filesystem::path& path,
                                                               SampleCacheOptions options) {
  MVBRDF_RETURN_IF_ERROR(options.Check());
  MVBRDF_ASSIGN_OR_RETURN(std::unique_ptr<SqliteDb> db, OpenStoreDb(path));
  return std::unique_ptr<SampleCache>(new SampleCache(std::move(db), options));
}

absl::Status SampleCache::Put(const SampleKey& key, absl::string_view bytes, int64_t now_ms,
                              absl::string_view known_sha256, absl::string_view pin_for_job) {
  // Hashing and compressing outside the lock: they are the slow part.
  const std::string sha256 = known_sha256.empty() ? Sha256Hex(bytes) : std::string(known_sha256);
  MVBRDF_ASSIGN_OR_RETURN(std::string stored, ZlibCompress(bytes, {options_.compression_level}));
  const auto stored_size = static_cast<int64_t>(stored.size());
  if (options_.max_stored_bytes > 0 && stored_size > options_.max_stored_bytes) {
    return absl::ResourceExhaustedError(absl::StrCat("sample cache: entry ", key.ToString(), " needs ",
                                                     stored_size, " bytes compressed, the cache holds at most ",
                                                     options_.max_stored_bytes, " (raise sample_cache_max_bytes)"));
  }
  {
    std::lock_guard<std::mutex> lock(mu_);
    ForgetLocked(key);  // never two copies of one entry in memory
  }
  std::string copy;
  if (Keeps(bytes.size())) copy.assign(bytes.data(), bytes.size());
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(Transaction transaction, Transaction::Begin(*db_));
  MVBRDF_ASSIGN_OR_RETURN(
      Statement insert,
      Statement::Prepare(*db_,
                         "INSERT OR REPLACE INTO sample_cache (sequence_hash, configuration, sample_level, "
                         "options_hash, data, raw_size, stored_size, sha256, created_ms, last_used_ms) "
                         "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?9)"));
  MVBRDF_RETURN_IF_ERROR(BindKey(insert, key));
  MVBRDF_RETURN_IF_ERROR(insert.BindBlobNoCopy(5, stored));  // `stored` outlives the insert
  MVBRDF_RETURN_IF_ERROR(insert.BindInt64(6, static_cast<int64_t>(bytes.size())));
  MVBRDF_RETURN_IF_ERROR(insert.BindInt64(7, stored_size));
  MVBRDF_RETURN_IF_ERROR(insert.BindText(8, sha256));
  MVBRDF_RETURN_IF_ERROR(insert.BindInt64(9, now_ms));
  MVBRDF_RETURN_IF_ERROR(insert.Run());
  if (!pin_for_job.empty()) MVBRDF_RETURN_IF_ERROR(PinLocked(key, pin_for_job));
  MVBRDF_RETURN_IF_ERROR(EvictLocked(key));
  MVBRDF_RETURN_IF_ERROR(transaction.Commit());
  if (Keeps(bytes.size())) KeepLocked(key, sha256, std::move(copy));
  return absl::OkStatus();
}

absl::Status SampleCache::Pin(const SampleKey& key, absl::string_view job_id) {
  std::lock_guard<std::mutex> lock(mu_);
  return PinLocked(key, job_id);
}

absl::Status SampleCache::PinLocked(const SampleKey& key, absl::string_view job_id) {
  if (job_id.empty()) return absl::InvalidArgumentError("SampleCache::Pin: job_id is empty");
  MVBRDF_ASSIGN_OR_RETURN(Statement pin, Statement::Prepare(*db_,
                                                            "INSERT OR IGNORE INTO sample_cache_pins (sequence_hash, "
                                                            "configuration, sample_level, options_hash, job_id) "
                                                            "VALUES (?1, ?2, ?3, ?4, ?5)"));
  MVBRDF_RETURN_IF_ERROR(BindKey(pin, key));
  MVBRDF_RETURN_IF_ERROR(pin.BindText(5, job_id));
  absl::Status run = pin.Run();
  if (!run.ok()) {
    return absl::Status(run.code(), absl::StrCat("sample cache: pinning ", key.ToString(), " for job ", job_id, ": ",
                                                 run.message()));
  }
  return absl::OkStatus();
}

bool SampleCache::Keeps(size_t bytes) const { return static_cast<int64_t>(bytes) <= options_.memory_bytes; }

std::list<SampleCache::Recent>::iterator SampleCache::FindRecentLocked(const SampleKey& key) {
  return std::find_if(recent_.begin(), recent_.end(), [&key](const Recent& r) {
    return r.key.sequence_hash == key.sequence_hash && r.key.configuration == key.configuration &&
           r.key.sample_level == key.sample_level && r.key.options_hash == key.options_hash;
  });
}

void SampleCache::ForgetLocked(const SampleKey& key) {
  const auto it = FindRecentLocked(key);
  if (it == recent_.end()) return;
  recent_bytes_ -= static_cast<int64_t>(it->bytes.size());
  recent_.erase(it);
}

void SampleCache::KeepLocked(const SampleKey& key, absl::string_view sha256, std::string bytes) {
  ForgetLocked(key);
  if (!Keeps(bytes.size())) return;
  recent_bytes_ += static_cast<int64_t>(bytes.size());
  recent_.push_front(Recent{key, std::string(sha256), std::move(bytes)});
  while (recent_bytes_ > options_.memory_bytes) {
    recent_bytes_ -= static_cast<int64_t>(recent_.back().bytes.size());
    recent_.pop_back();
  }
}

absl::StatusOr<bool> SampleCache::TouchLocked(const SampleKey& key, int64_t now_ms) {
  MVBRDF_ASSIGN_OR_RETURN(
      Statement touch,
      Statement::Prepare(*db_, absl::StrCat("UPDATE sample_cache SET last_used_ms = ?5 WHERE ", kKeyWhere)));
  MVBRDF_RETURN_IF_ERROR(BindKey(touch, key));
  MVBRDF_RETURN_IF_ERROR(touch.BindInt64(5, now_ms));
  MVBRDF_RETURN_IF_ERROR(touch.Run());
  return db_->Changes() == 1;
}

absl::StatusOr<std::optional<std::string>> SampleCache::Get(const SampleKey& key, int64_t now_ms,
                                                            std::string* sha256) {
  std::lock_guard<std::mutex> lock(mu_);
  if (const auto recent = FindRecentLocked(key); recent != recent_.end()) {
    // The bytes were verified when kept; the row must still be there (another
    // connection may have erased it), and its use is stamped as any hit's.
    MVBRDF_ASSIGN_OR_RETURN(const bool present, TouchLocked(key, now_ms));
    if (present) {
      ++counters_.hits;
      ++counters_.memory_hits;
      recent_.splice(recent_.begin(), recent_, recent);
      if (sha256 != nullptr) *sha256 = recent->sha256;
      return std::optional<std::string>(recent->bytes);
    }
    ForgetLocked(key);
  }
  MVBRDF_ASSIGN_OR_RETURN(
      Statement select,
      Statement::Prepare(*db_, absl::StrCat("SELECT data, raw_size, sha256 FROM sample_cache WHERE ", kKeyWhere)));
  MVBRDF_RETURN_IF_ERROR(BindKey(select, key));
  MVBRDF_ASSIGN_OR_RETURN(StepResult step, select.Step());
  if (step == StepResult::kDone) {
    ++counters_.misses;
    return std::optional<std::string>();
  }
  const std::string stored = select.ColumnBlob(0);
  const int64_t raw_size = select.ColumnInt64(1);
  const std::string expected_sha256 = select.ColumnText(2);
  MVBRDF_RETURN_IF_ERROR(select.Reset());  // ends the read before the writes below

  std::string bytes;
  std::string problem;
  if (raw_size < 0) {
    problem = absl::StrCat("negative raw_size ", raw_size);
  } else {
    problem = Uncompress(stored, static_cast<size_t>(raw_size), &bytes);
  }
  if (problem.empty()) {
    const std::string actual = Sha256Hex(bytes);
    if (actual != expected_sha256) {
      problem = absl::StrCat("SHA-256 ", actual, " does not match the stored ", expected_sha256);
    }
  }
  if (!problem.empty()) {
    ++counters_.corrupt;
    MVBRDF_RETURN_IF_ERROR(EraseLocked(key));
    return absl::DataLossError(
        absl::StrCat("sample cache entry ", key.ToString(), " is corrupt (", problem, "); removed it"));
  }

  MVBRDF_RETURN_IF_ERROR(TouchLocked(key, now_ms).status());
  ++counters_.hits;
  if (sha256 != nullptr) *sha256 = expected_sha256;
  if (Keeps(bytes.size())) KeepLocked(key, expected_sha256, bytes);
  return std::optional<std::string>(std::move(bytes));
}

absl::Status SampleCache::Erase(const SampleKey& key) {
  std::lock_guard<std::mutex> lock(mu_);
  return EraseLocked(key);
}

absl::StatusOr<SampleCacheStats> SampleCache::Stats() {
  std::lock_guard<std::mutex> lock(mu_);
  SampleCacheStats stats = counters_;
  MVBRDF_ASSIGN_OR_RETURN(
      Statement totals,
      Statement::Prepare(*db_,
                         "SELECT COUNT(*), COALESCE(SUM(stored_size), 0), COALESCE(SUM(raw_size), 0) "
                         "FROM sample_cache"));
  MVBRDF_ASSIGN_OR_RETURN(StepResult step, totals.Step());
  if (step != StepResult::kRow) return absl::InternalError("sample cache: COUNT returned no row");
  stats.entries = totals.ColumnInt64(0);
  stats.stored_bytes = totals.ColumnInt64(1);
  stats.raw_bytes = totals.ColumnInt64(2);
  return stats;
}

absl::Status SampleCache::EraseLocked(const SampleKey& key) {
  ForgetLocked(key);
  MVBRDF_ASSIGN_OR_RETURN(Statement erase,
                          Statement::Prepare(*db_, absl::StrCat("DELETE FROM sample_cache WHERE ", kKeyWhere)));
  MVBRDF_RETURN_IF_ERROR(BindKey(erase, key));
  return erase.Run();
}

absl::Status SampleCache::EvictLocked(const SampleKey& keep) {
  if (options_.max_stored_bytes == 0) return absl::OkStatus();
  MVBRDF_ASSIGN_OR_RETURN(Statement total,
                          Statement::Prepare(*db_, "SELECT COALESCE(SUM(stored_size), 0) FROM sample_cache"));
  MVBRDF_ASSIGN_OR_RETURN(StepResult step, total.Step());
  if (step != StepResult::kRow) return absl::InternalError("sample cache: SUM returned no row");
  int64_t stored_bytes = total.ColumnInt64(0);
  if (stored_bytes <= options_.max_stored_bytes) return absl::OkStatus();

  // Pins of jobs that have ended protect nothing any more.
  MVBRDF_RETURN_IF_ERROR(db_->Exec(
      "DELETE FROM sample_cache_pins WHERE job_id NOT IN "
      "(SELECT id FROM jobs WHERE state IN ('queued', 'running'))"));
  // Oldest use first; the entry just put stays (it fits on its own), and so
  // do the entries pinned by jobs still in flight.
  MVBRDF_ASSIGN_OR_RETURN(
      Statement oldest,
      Statement::Prepare(*db_, absl::StrCat("SELECT rowid, stored_size FROM sample_cache WHERE NOT (", kKeyWhere,
                                            ") AND NOT EXISTS (SELECT 1 FROM sample_cache_pins p WHERE "
                                            "p.sequence_hash = sample_cache.sequence_hash AND "
                                            "p.configuration = sample_cache.configuration AND "
                                            "p.sample_level = sample_cache.sample_level AND "
                                            "p.options_hash = sample_cache.options_hash) "
                                            "ORDER BY last_used_ms, rowid")));
  MVBRDF_RETURN_IF_ERROR(BindKey(oldest, keep));
  std::vector<int64_t> victims;
  while (stored_bytes > options_.max_stored_bytes) {
    MVBRDF_ASSIGN_OR_RETURN(StepResult row, oldest.Step());
    if (row == StepResult::kDone) break;
    victims.push_back(oldest.ColumnInt64(0));
    stored_bytes -= oldest.ColumnInt64(1);
  }
  MVBRDF_RETURN_IF_ERROR(oldest.Reset());
  MVBRDF_ASSIGN_OR_RETURN(Statement erase, Statement::Prepare(*db_, "DELETE FROM sample_cache WHERE rowid = ?1"));
  for (int64_t rowid : victims) {
    MVBRDF_RETURN_IF_ERROR(erase.BindInt64(1, rowid));
    MVBRDF_RETURN_IF_ERROR(erase.Run());
    MVBRDF_RETURN_IF_ERROR(erase.Reset());
  }
  counters_.evictions += static_cast<int64_t>(victims.size());
  return absl::OkStatus();
}

}  // namespace mvbrdf::store
