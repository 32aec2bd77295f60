#include "server/store/artifact_store.h"

#include <gtest/gtest.h>

#include <fstream>
#include <memory>
#include <string>

#include "core/base/files.h"
#include "server/store/digest.h"
#include "server/store/test_dir.h"

namespace mvbrdf::store {
namespace {

constexpr int64_t kT0 = 1'700'000'000'000;

size_t CountFiles(const std::filesystem::path& dir) {
  size_t count = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file()) ++count;
  }
  return count;
}

TEST(ArtifactStoreTest, IdenticalContentIsStoredOnce) {
  TestDir dir;
  auto store = ArtifactStore::Open(dir.db(), dir.path() / "artifacts");
  ASSERT_TRUE(store.ok()) << store.status();
  const std::string bytes = "kd atlas bytes";
  auto first = (*store)->PutBytes("job1", "atlas/kd.exr", bytes, kT0);
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_EQ(first->sha256, Sha256Hex(bytes));
  EXPECT_EQ(first->size, static_cast<int64_t>(bytes.size()));

  // The same content from a file, under another job and name.
  const std::filesystem::path source = dir.path() / "source.bin";
  ASSERT_TRUE(WriteStringToFile(source, bytes).ok());
  auto second = (*store)->PutFile("job2", "copy.exr", source, kT0 + 1);
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_EQ(second->sha256, first->sha256);
  EXPECT_EQ(CountFiles(dir.path() / "artifacts"), 1u);  // tmp/ is empty again

  auto path = (*store)->PathOf(first->sha256);
  ASSERT_TRUE(path.ok());
  EXPECT_EQ(*path, dir.path() / "artifacts" / first->sha256.substr(0, 2) / first->sha256);
  auto read = (*store)->Read(first->sha256);
  ASSERT_TRUE(read.ok()) << read.status();
  EXPECT_EQ(*read, bytes);

  auto of_job = (*store)->ArtifactsOfJob("job2");
  ASSERT_TRUE(of_job.ok());
  ASSERT_EQ(of_job->size(), 1u);
  EXPECT_EQ((*of_job)[0].name, "copy.exr");

  auto other = (*store)->PutBytes("job1", "table.csv", "a,b\n1,2\n", kT0 + 2);
  ASSERT_TRUE(other.ok());
  EXPECT_EQ(CountFiles(dir.path() / "artifacts"), 2u);
}

TEST(ArtifactStoreTest, TamperedFileIsDetected) {
  TestDir dir;
  auto store = ArtifactStore::Open(dir.db(), dir.path() / "artifacts");
  ASSERT_TRUE(store.ok()) << store.status();
  auto artifact = (*store)->PutBytes("job", "image.png", std::string(10000, 'p'), kT0);
  ASSERT_TRUE(artifact.ok());
  auto path = (*store)->OpenVerified(artifact->sha256);
  ASSERT_TRUE(path.ok()) << path.status();
  {
    std::fstream file(*path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(5000);
    file.put('q');
  }
  auto read = (*store)->Read(artifact->sha256);
  EXPECT_EQ(read.status().code(), absl::StatusCode::kDataLoss) << read.status();
  EXPECT_NE(read.status().message().find(artifact->sha256), absl::string_view::npos);
  EXPECT_EQ((*store)->OpenVerified(artifact->sha256).status().code(), absl::StatusCode::kDataLoss);

  // Putting the content again repairs the damaged copy.
  ASSERT_TRUE((*store)->PutBytes("job2", "image.png", std::string(10000, 'p'), kT0 + 1).ok());
  EXPECT_TRUE((*store)->Read(artifact->sha256).ok());
}

TEST(ArtifactStoreTest, OnlyValidDigestsBecomePaths) {
  TestDir dir;
  auto store = ArtifactStore::Open(dir.db(), dir.path() / "artifacts");
  ASSERT_TRUE(store.ok());
  EXPECT_EQ((*store)->Read("../../store.db").status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ((*store)->Read(std::string(64, 'G')).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ((*store)->Read(Sha256Hex("never stored")).status().code(), absl::StatusCode::kNotFound);
  // Names with path syntax are only index data.
  auto named = (*store)->PutBytes("job", "../../escape", "x", kT0);
  ASSERT_TRUE(named.ok());
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "escape"));
  EXPECT_FALSE(std::filesystem::exists(dir.path().parent_path() / "escape"));
}

}  // namespace
}  // namespace mvbrdf::store
