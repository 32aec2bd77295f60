// The Sample cache (issue #5): encoded SampleSets (samples::EncodeSampleSet)
// per (sequence, light configuration, sample level, options), stored in
// SQLite zlib-compressed with the SHA-256 of the uncompressed bytes, so a
// repeated sweep on the same sequence skips resampling.
//
// A corrupt entry (checksum or zlib failure) is deleted and reported as
// DATA_LOSS: the caller recomputes and Puts again. The cache holds at most
// `max_stored_bytes` of compressed data; Put evicts the least recently used
// entries (Get and Put stamp last_used_ms) to make room, except those pinned
// by a job that is still queued or running (Pin): a job's Samples stay until
// it has used them, even when that holds the cache over its limit for a while
// (bounded by the jobs in flight; the next Put after they end evicts).
//
// The entries last Put or read are kept uncompressed in memory as well, up to
// `memory_bytes` (issue #17): a Get of one of them answers from that copy,
// verified when it was kept, while its row is still in the table; a row
// corrupted meanwhile is found at the next read from the database.
//
// Threading: every method may be called from any thread (a mutex serialises
// them). Other stores may use the same database file through their own
// connections.
#ifndef MVBRDF_SERVER_STORE_SAMPLE_CACHE_H_
#define MVBRDF_SERVER_STORE_SAMPLE_CACHE_H_

#include <cstdint>
#include <filesystem>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/store/sqlite_db.h"

namespace mvbrdf::store {

struct SampleKey {
  std::string sequence_hash;  // SHA-256 hex of the sequence bundle
  std::string configuration;  // the light configuration, e.g. "key+fill"
  int sample_level = 0;       // triangle / texel level of the Samples
  std::string options_hash;   // hash of the options that change the Samples

  // For messages: "sequence/configuration/level/options".
  std::string ToString() const;
};

struct SampleCacheOptions {
  // Upper bound on the compressed bytes held; 0: unlimited.
  int64_t max_stored_bytes = int64_t{2} << 30;
  // zlib level, 1 (fast) .. 9 (small).
  int compression_level = 1;  // float Samples gain little from more (measured on samba: see the #5 note)
  // The entries last Put or read are also kept uncompressed in memory, up
  // to this many bytes in all (least recently used dropped first; 0: none).
  // A job's sweep tasks fetch the Samples its gather has just stored, once
  // per worker, and each Get from the database reads, inflates and hashes
  // them again (35 MB: ~0.45 s).
  int64_t memory_bytes = int64_t{256} << 20;

  absl::Status Check() const;
};

struct SampleCacheStats {
  // Counted by this SampleCache object since it was opened.
  int64_t hits = 0;
  int64_t misses = 0;
  int64_t corrupt = 0;    // entries found corrupt and removed
  int64_t evictions = 0;  // entries evicted for space
  int64_t memory_hits = 0;  // hits answered from the entries kept in memory (also counted in hits)
  // The table as it is now (all connections).
  int64_t entries = 0;
  int64_t stored_bytes = 0;  // compressed
  int64_t raw_bytes = 0;     // uncompressed
};

class SampleCache {
 public:
  static absl::StatusOr<std::unique_ptr<SampleCache>> Open(const std::filesystem::path& path,
                                                           SampleCacheOptions options = {});

  // Stores (or replaces) the entry, then evicts least recently used entries
  // until the total fits. RESOURCE_EXHAUSTED when the entry alone is larger
  // than the limit (nothing stored).
  // `known_sha256`: the SHA-256 of `bytes` when the caller has verified it
  // already (saves hashing large entries twice); computed when empty.
  // `pin_for_job`: also Pin the entry for that job (in the same transaction,
  // so no other Put evicts it in between).
  absl::Status Put(const SampleKey& key, absl::string_view bytes, int64_t now_ms,
                   absl::string_view known_sha256 = {}, absl::string_view pin_for_job = {});
  // The bytes given to Put, or nullopt on a miss (from memory when the entry
  // is kept there and its row is still in the table). DATA_LOSS naming the key
  // when the stored entry is corrupt; the entry is then gone. On a hit,
  // `sha256` (when given) receives the bytes' SHA-256, hex, which Get has
  // just verified (a caller need not hash them again).
  absl::StatusOr<std::optional<std::string>> Get(const SampleKey& key, int64_t now_ms,
                                                 std::string* sha256 = nullptr);
  // Removes the entry if present.
  absl::Status Erase(const SampleKey& key);
  // Keeps the entry (present or later Put) from eviction while job `job_id`
  // (a row of the jobs table in the same database) is queued or running.
  // Pins of ended jobs are dropped by the next eviction pass.
  absl::Status Pin(const SampleKey& key, absl::string_view job_id);

  absl::StatusOr<SampleCacheStats> Stats();

 private:
  SampleCache(std::unique_ptr<SqliteDb> db, SampleCacheOptions options) : db_(std::move(db)), options_(options) {}

  // An entry kept in memory (SampleCacheOptions::memory_bytes).
  struct Recent {
    SampleKey key;
    std::string sha256;
    std::string bytes;
  };
  bool Keeps(size_t bytes) const;  // whether an entry of `bytes` is kept in memory
  // Keeps the entry first in recent_, dropping the least recently used ones
  // beyond memory_bytes.
  void KeepLocked(const SampleKey& key, absl::string_view sha256, std::string bytes);
  std::list<Recent>::iterator FindRecentLocked(const SampleKey& key);
  void ForgetLocked(const SampleKey& key);
  // Stamps the entry's last use; whether its row is in the table.
  absl::StatusOr<bool> TouchLocked(const SampleKey& key, int64_t now_ms);
  absl::Status EraseLocked(const SampleKey& key);
  absl::Status EvictLocked(const SampleKey& keep);
  absl::Status PinLocked(const SampleKey& key, absl::string_view job_id);

  std::mutex mu_;
  std::unique_ptr<SqliteDb> db_;  // guarded by mu_
  const SampleCacheOptions options_;
  SampleCacheStats counters_;  // guarded by mu_; only the counted fields
  std::list<Recent> recent_;  // guarded by mu_; most recently used first
  int64_t recent_bytes_ = 0;  // guarded by mu_; the bytes of recent_
};

}  // namespace mvbrdf::store

#endif  // MVBRDF_SERVER_STORE_SAMPLE_CACHE_H_
