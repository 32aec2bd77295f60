#include "server/store/sample_cache.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <utility>
#include <random>
#include <string>

#include "core/base/draw_order.h"
#include "core/samples/sample_set.h"
#include "server/store/digest.h"
#include "server/store/job_store.h"
#include "server/store/sqlite_db.h"
#include "server/store/test_dir.h"

namespace mvbrdf::store {
namespace {

constexpr int64_t kT0 = 1'700'000'000'000;

samples::SampleSet MakeSampleSet(int count) {
  samples::SampleSet set;
  set.light_names = {"key", "fill", "rim"};
  set.light_intensity = {glm::vec3(1.0f), glm::vec3(0.5f, 0.4f, 0.3f), glm::vec3(2.0f)};
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (int i = 0; i < count; ++i) {
    const float g[3] = {unit(rng), unit(rng), 0.0f};
    const float h[3] = {unit(rng), 0.0f, unit(rng)};
    set.Add(static_cast<uint32_t>(i * 3), i % 40, i % 4, base::DrawVec3<glm::vec3>([&] { return unit(rng); }), g, h);
  }
  return set;
}

SampleKey Key(const std::string& configuration) {
  return SampleKey{"seqhash", configuration, 1, "opts"};
}

std::unique_ptr<SampleCache> OpenOrDie(const std::filesystem::path& path, SampleCacheOptions options = {}) {
  auto cache = SampleCache::Open(path, options);
  EXPECT_TRUE(cache.ok()) << cache.status();
  return cache.ok() ? std::move(*cache) : nullptr;
}

TEST(SampleCacheTest, RoundTripsAnEncodedSampleSet) {
  TestDir dir;
  auto cache = OpenOrDie(dir.db());
  const samples::SampleSet set = MakeSampleSet(2000);
  const std::string bytes = samples::EncodeSampleSet(set);

  auto miss = cache->Get(Key("key+fill"), kT0);
  ASSERT_TRUE(miss.ok()) << miss.status();
  EXPECT_FALSE(miss->has_value());
  ASSERT_TRUE(cache->Put(Key("key+fill"), bytes, kT0).ok());
  std::string sha256;
  auto hit = cache->Get(Key("key+fill"), kT0 + 1, &sha256);
  ASSERT_TRUE(hit.ok()) << hit.status();
  ASSERT_TRUE(hit->has_value());
  EXPECT_EQ(**hit, bytes);
  EXPECT_EQ(sha256, Sha256Hex(bytes));  // the digest Get verified, handed out
  auto decoded = samples::DecodeSampleSet(**hit);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(decoded->size(), set.size());
  EXPECT_EQ(decoded->light_names, set.light_names);
  EXPECT_EQ(decoded->element, set.element);

  // The rest of the key matters.
  auto other_level = cache->Get(SampleKey{"seqhash", "key+fill", 2, "opts"}, kT0 + 2);
  ASSERT_TRUE(other_level.ok());
  EXPECT_FALSE(other_level->has_value());

  auto stats = cache->Stats();
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats->hits, 1);
  EXPECT_EQ(stats->misses, 2);
  EXPECT_EQ(stats->entries, 1);
  EXPECT_EQ(stats->raw_bytes, static_cast<int64_t>(bytes.size()));
  EXPECT_LT(stats->stored_bytes, stats->raw_bytes);  // compressed

  // A new connection (server restart) sees the entry.
  cache.reset();
  auto reopened = OpenOrDie(dir.db());
  auto again = reopened->Get(Key("key+fill"), kT0 + 3);
  ASSERT_TRUE(again.ok());
  ASSERT_TRUE(again->has_value());
  EXPECT_EQ(**again, bytes);
}

// The database's own checks: no copy in memory (SampleCacheOptions::
// memory_bytes 0), which would answer from the bytes Put kept instead.
SampleCacheOptions DatabaseOnly() {
  SampleCacheOptions options;
  options.memory_bytes = 0;
  return options;
}

TEST(SampleCacheTest, CorruptEntryIsDataLossAndRemoved) {
  TestDir dir;
  auto cache = OpenOrDie(dir.db(), DatabaseOnly());
  const std::string bytes = samples::EncodeSampleSet(MakeSampleSet(500));
  ASSERT_TRUE(cache->Put(Key("key"), bytes, kT0).ok());
  {
    // Flip one byte in the middle of the stored blob behind the cache's back.
    auto db = SqliteDb::Open(dir.db());
    ASSERT_TRUE(db.ok());
    auto read = Statement::Prepare(**db, "SELECT data FROM sample_cache");
    ASSERT_TRUE(read.ok());
    auto step = read->Step();
    ASSERT_TRUE(step.ok());
    std::string data = read->ColumnBlob(0);
    ASSERT_FALSE(data.empty());
    data[data.size() / 2] = static_cast<char>(data[data.size() / 2] ^ 0x5a);
    auto write = Statement::Prepare(**db, "UPDATE sample_cache SET data = ?1");
    ASSERT_TRUE(write.ok());
    ASSERT_TRUE(write->BindBlob(1, data).ok());
    ASSERT_TRUE(write->Run().ok());
  }
  auto corrupt = cache->Get(Key("key"), kT0 + 1);
  ASSERT_FALSE(corrupt.ok());
  EXPECT_EQ(corrupt.status().code(), absl::StatusCode::kDataLoss);
  EXPECT_NE(corrupt.status().message().find(Key("key").ToString()), absl::string_view::npos) << corrupt.status();
  auto gone = cache->Get(Key("key"), kT0 + 2);
  ASSERT_TRUE(gone.ok()) << gone.status();
  EXPECT_FALSE(gone->has_value());

  ASSERT_TRUE(cache->Put(Key("key"), bytes, kT0 + 3).ok());  // the caller recomputed
  auto fixed = cache->Get(Key("key"), kT0 + 4);
  ASSERT_TRUE(fixed.ok()) << fixed.status();
  ASSERT_TRUE(fixed->has_value());
  EXPECT_EQ(**fixed, bytes);
  auto stats = cache->Stats();
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats->corrupt, 1);
}

TEST(SampleCacheTest, ChecksumMismatchAloneIsDetected) {
  TestDir dir;
  auto cache = OpenOrDie(dir.db(), DatabaseOnly());
  ASSERT_TRUE(cache->Put(Key("key"), "some sample bytes", kT0).ok());
  {
    auto db = SqliteDb::Open(dir.db());
    ASSERT_TRUE(db.ok());
    // Valid zlib data of other content: only the SHA-256 can tell.
    ASSERT_TRUE((*db)->Exec("UPDATE sample_cache SET sha256 = '" + std::string(64, '0') + "'").ok());
  }
  auto corrupt = cache->Get(Key("key"), kT0 + 1);
  EXPECT_EQ(corrupt.status().code(), absl::StatusCode::kDataLoss) << corrupt.status();
  EXPECT_NE(corrupt.status().message().find("SHA-256"), absl::string_view::npos) << corrupt.status();
}

TEST(SampleCacheTest, KeepsTheLastEntryPutOrReadInMemory) {
  TestDir dir;
  const std::string a = samples::EncodeSampleSet(MakeSampleSet(300));
  const std::string b = samples::EncodeSampleSet(MakeSampleSet(400));
  SampleCacheOptions options;
  options.memory_bytes = static_cast<int64_t>(std::max(a.size(), b.size()));
  auto cache = OpenOrDie(dir.db(), options);
  const auto stats = [&cache]() {
    auto s = cache->Stats();
    EXPECT_TRUE(s.ok()) << s.status();
    return s.ok() ? *s : SampleCacheStats();
  };
  const auto get = [&cache](const std::string& configuration, int64_t now_ms) {
    std::string sha256;
    auto got = cache->Get(Key(configuration), now_ms, &sha256);
    EXPECT_TRUE(got.ok()) << got.status();
    return got.ok() && got->has_value() ? std::make_pair(**got, sha256) : std::make_pair(std::string(), sha256);
  };

  // Put keeps its entry: the next Get of it is answered from memory, with the
  // digest, and stamps its use like any hit.
  ASSERT_TRUE(cache->Put(Key("a"), a, kT0).ok());
  EXPECT_EQ(get("a", kT0 + 1), std::make_pair(a, Sha256Hex(a)));
  EXPECT_EQ(stats().hits, 1);
  EXPECT_EQ(stats().memory_hits, 1);
  {
    auto db = SqliteDb::Open(dir.db());
    ASSERT_TRUE(db.ok());
    auto used = Statement::Prepare(**db, "SELECT last_used_ms FROM sample_cache");
    ASSERT_TRUE(used.ok());
    ASSERT_TRUE(used->Step().ok());
    EXPECT_EQ(used->ColumnInt64(0), kT0 + 1);
  }

  // Another Put replaces the copy; a Get from the database keeps what it read.
  ASSERT_TRUE(cache->Put(Key("b"), b, kT0 + 2).ok());
  EXPECT_EQ(get("a", kT0 + 3).first, a);
  EXPECT_EQ(stats().memory_hits, 1);
  EXPECT_EQ(get("a", kT0 + 4).first, a);
  EXPECT_EQ(stats().memory_hits, 2);
  EXPECT_EQ(get("b", kT0 + 5).first, b);
  EXPECT_EQ(stats().memory_hits, 2);

  // An entry erased, here or by another connection, is a miss, not the copy.
  ASSERT_TRUE(cache->Erase(Key("b")).ok());
  EXPECT_EQ(get("b", kT0 + 6).first, "");
  EXPECT_EQ(get("a", kT0 + 7).first, a);  // from the database: now the copy
  {
    auto db = SqliteDb::Open(dir.db());
    ASSERT_TRUE(db.ok());
    ASSERT_TRUE((*db)->Exec("DELETE FROM sample_cache").ok());
  }
  EXPECT_EQ(get("a", kT0 + 8).first, "");
  EXPECT_EQ(stats().memory_hits, 2);
  EXPECT_EQ(stats().misses, 2);

  // Several entries fit together: a small one Put after a large one (a
  // gather's cameras after its Samples) does not push the large one out.
  options.memory_bytes = static_cast<int64_t>(a.size()) + 100;
  cache = OpenOrDie(dir.db(), options);
  ASSERT_TRUE(cache->Put(Key("a"), a, kT0 + 9).ok());
  ASSERT_TRUE(cache->Put(Key("cameras"), "calibration", kT0 + 9).ok());
  EXPECT_EQ(get("a", kT0 + 10).first, a);
  EXPECT_EQ(get("cameras", kT0 + 10).first, "calibration");
  EXPECT_EQ(stats().memory_hits, 2);

  // Larger than memory_bytes: never kept.
  options.memory_bytes = static_cast<int64_t>(a.size()) - 1;
  cache = OpenOrDie(dir.db(), options);
  ASSERT_TRUE(cache->Put(Key("a"), a, kT0 + 9).ok());
  EXPECT_EQ(get("a", kT0 + 10).first, a);
  EXPECT_EQ(get("a", kT0 + 11).first, a);
  EXPECT_EQ(stats().hits, 2);
  EXPECT_EQ(stats().memory_hits, 0);

  options.memory_bytes = -1;
  EXPECT_EQ(SampleCache::Open(dir.db(), options).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(SampleCacheTest, EvictsLeastRecentlyUsed) {
  TestDir dir;
  // Random bytes do not compress: each entry stores ~1000 bytes.
  std::mt19937 rng(3);
  auto random_bytes = [&rng] {
    std::string bytes(1000, '\0');
    for (char& c : bytes) c = static_cast<char>(rng() & 0xff);
    return bytes;
  };
  auto cache = OpenOrDie(dir.db(), SampleCacheOptions{/*max_stored_bytes=*/2600, /*compression_level=*/6});
  const std::string a = random_bytes(), b = random_bytes(), c = random_bytes();
  ASSERT_TRUE(cache->Put(Key("a"), a, kT0).ok());
  ASSERT_TRUE(cache->Put(Key("b"), b, kT0 + 1).ok());
  ASSERT_TRUE(cache->Get(Key("a"), kT0 + 2).ok());  // a is now newer than b
  ASSERT_TRUE(cache->Put(Key("c"), c, kT0 + 3).ok());

  auto has = [&](const std::string& name) {
    auto got = cache->Get(Key(name), kT0 + 10);
    EXPECT_TRUE(got.ok()) << got.status();
    return got.ok() && got->has_value();
  };
  EXPECT_FALSE(has("b"));
  EXPECT_TRUE(has("a"));
  EXPECT_TRUE(has("c"));
  auto stats = cache->Stats();
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats->evictions, 1);
  EXPECT_EQ(stats->entries, 2);
  EXPECT_LE(stats->stored_bytes, 2600);

  const std::string huge(1 << 16, 'x');  // compresses well: fits
  EXPECT_TRUE(cache->Put(Key("huge"), huge, kT0 + 20).ok());
  std::string too_big;
  for (int i = 0; i < 4; ++i) too_big += random_bytes();
  EXPECT_EQ(cache->Put(Key("too big"), too_big, kT0 + 21).code(), absl::StatusCode::kResourceExhausted);
}

// Issue #17: an eviction mid-job made the job regather its Samples. An entry
// pinned by a job that is still queued or running is not evicted, even when
// that holds the cache over its limit; once the job has ended the next Put
// evicts it as usual, and its pin is gone.
TEST(SampleCacheTest, EntriesPinnedByUnfinishedJobsAreNotEvicted) {
  TestDir dir;
  auto jobs = JobStore::Open(dir.db());
  ASSERT_TRUE(jobs.ok()) << jobs.status();
  auto job = (*jobs)->CreateJob(NewJob{"alice", "scenehash", "request"}, kT0);
  ASSERT_TRUE(job.ok()) << job.status();
  std::mt19937 rng(5);
  auto random_bytes = [&rng] {
    std::string bytes(1000, '\0');
    for (char& c : bytes) c = static_cast<char>(rng() & 0xff);
    return bytes;
  };
  auto cache = OpenOrDie(dir.db(), SampleCacheOptions{/*max_stored_bytes=*/2600, /*compression_level=*/6});
  EXPECT_EQ(cache->Pin(Key("a"), "").code(), absl::StatusCode::kInvalidArgument);
  ASSERT_TRUE(cache->Put(Key("a"), random_bytes(), kT0, {}, *job).ok());  // put and pinned at once
  ASSERT_TRUE(cache->Put(Key("b"), random_bytes(), kT0 + 1).ok());
  ASSERT_TRUE(cache->Pin(Key("b"), *job).ok());                            // pinned after the fact
  ASSERT_TRUE(cache->Put(Key("c"), random_bytes(), kT0 + 2).ok());         // over the limit: nothing to evict
  auto has = [&](const std::string& name) {
    auto got = cache->Get(Key(name), kT0 + 10);
    EXPECT_TRUE(got.ok()) << got.status();
    return got.ok() && got->has_value();
  };
  EXPECT_TRUE(has("a"));
  EXPECT_TRUE(has("b"));
  EXPECT_TRUE(has("c"));
  auto stats = cache->Stats();
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats->evictions, 0);
  EXPECT_GT(stats->stored_bytes, 2600);

  // The job ends: the next Put evicts the least recently used ones again.
  ASSERT_TRUE((*jobs)->CancelJob(*job, kT0 + 20).ok());
  ASSERT_TRUE(cache->Put(Key("d"), random_bytes(), kT0 + 21).ok());
  stats = cache->Stats();
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats->evictions, 2);
  EXPECT_LE(stats->stored_bytes, 2600);
  EXPECT_TRUE(has("d"));
  auto db = SqliteDb::Open(dir.db());
  ASSERT_TRUE(db.ok()) << db.status();
  auto pins = Statement::Prepare(**db, "SELECT COUNT(*) FROM sample_cache_pins");
  ASSERT_TRUE(pins.ok()) << pins.status();
  ASSERT_TRUE(pins->Step().ok());
  EXPECT_EQ(pins->ColumnInt64(0), 0);  // the ended job's pins were dropped
}

}  // namespace
}  // namespace mvbrdf::store
