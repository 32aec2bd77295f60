#include "core/pipeline/resampled_atlas_cache.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>

namespace mvbrdf::pipeline {
namespace {

// An atlas like a resampled one: charts of valid texels (a = 1), refused
// and invisible texels all zero, and values a compressor would get wrong:
// -0, a NaN payload, a denormal, a texel with only a = 0 and rgb set.
cv::Mat Atlas(int size, float value) {
  cv::Mat atlas(size, size, CV_32FC4, cv::Scalar::all(0));
  for (int y = 3; y < size - 5; ++y) {
    for (int x = y % 7; x < size - 2; x += 3) atlas.at<cv::Vec4f>(y, x) = {value + x, value * y, 0.25f, 1.0f};
  }
  atlas.at<cv::Vec4f>(0, 0) = {-0.0f, 0.0f, 0.0f, 0.0f};
  atlas.at<cv::Vec4f>(0, 1) = {std::numeric_limits<float>::quiet_NaN(), 1.0f, 2.0f, 1.0f};
  atlas.at<cv::Vec4f>(size - 1, size - 1) = {std::numeric_limits<float>::denorm_min(), 0.0f, 0.0f, 0.0f};
  atlas.at<cv::Vec4f>(1, size - 1) = {0.5f, 0.5f, 0.5f, 0.0f};
  return atlas;
}

bool BitForBit(const cv::Mat& a, const cv::Mat& b) {
  return a.type() == b.type() && a.size() == b.size() && std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

TEST(ResampledAtlasCacheTest, GivesBackTheAtlasKeptBitForBitWithItsRefusedCounts) {
  auto cache = ResampledAtlasCache::Create();
  ASSERT_TRUE(cache.ok()) << cache.status();
  EXPECT_FALSE((*cache)->Find(0, 0, "k").has_value());
  for (int t = 0; t < 3; ++t) {
    for (int c = 0; c < 2; ++c) {
      resample::Resampler::RefusedObservations refused{1u + t, 2u + c, 3, 4, 5u + 10u * t + c};
      EXPECT_TRUE((*cache)->Keep(t, c, "k", Atlas(64, 10.0f * t + c), refused));
    }
  }
  EXPECT_EQ((*cache)->size(), 6u);
  // Only the texels that are not all zero: far below the 64 KB of an atlas.
  EXPECT_LT((*cache)->bytes(), 6u * 32768u);
  for (int t = 2; t >= 0; --t) {
    for (int c = 0; c < 2; ++c) {
      const std::optional<ResampledAtlasCache::Kept> kept = (*cache)->Find(t, c, "k");
      ASSERT_TRUE(kept.has_value());
      EXPECT_TRUE(BitForBit(kept->atlas, Atlas(64, 10.0f * t + c))) << t << " " << c;
      EXPECT_EQ(kept->refused.masked, 1u + t);
      EXPECT_EQ(kept->refused.saturated, 2u + c);
      EXPECT_EQ(kept->refused.kept, 5u + 10u * t + c);
    }
  }
  // Another camera model or resampler option (the key): not this atlas.
  EXPECT_FALSE((*cache)->Find(1, 0, "other").has_value());
  EXPECT_FALSE((*cache)->Find(3, 0, "k").has_value());
  // Kept once: a second Keep of (t, c) changes nothing.
  EXPECT_FALSE((*cache)->Keep(0, 0, "k", Atlas(64, 99.0f), {}));
  EXPECT_TRUE(BitForBit((*cache)->Find(0, 0, "k")->atlas, Atlas(64, 0.0f)));
  // An all-zero atlas (a camera that sees nothing) is kept, and given back.
  (*cache)->Keep(5, 0, "k", cv::Mat(32, 48, CV_32FC4, cv::Scalar::all(0)), {});
  const auto empty = (*cache)->Find(5, 0, "k");
  ASSERT_TRUE(empty.has_value());
  EXPECT_EQ(empty->atlas.size(), cv::Size(48, 32));
  EXPECT_EQ(cv::countNonZero(empty->atlas.reshape(1)), 0);
}

TEST(ResampledAtlasCacheTest, KeepsNothingBeyondTheBudgetOrOfAnotherType) {
  auto cache = ResampledAtlasCache::Create(1000);
  ASSERT_TRUE(cache.ok());
  EXPECT_FALSE((*cache)->Keep(0, 0, "k", Atlas(64, 1.0f), {}));
  EXPECT_FALSE((*cache)->Keep(1, 0, "k", cv::Mat(8, 8, CV_32FC3, cv::Scalar::all(1)), {}));
  EXPECT_EQ((*cache)->size(), 0u);
  EXPECT_FALSE((*cache)->Find(0, 0, "k").has_value());
}

TEST(ResampledAtlasCacheTest, LeavesNoFileBehindAndRefusesAMissingDirectory) {
  const std::filesystem::path dir = std::filesystem::path(testing::TempDir()) / "resampled_atlas_cache_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  {
    auto cache = ResampledAtlasCache::Create(ResampledAtlasCache::kDefaultBudgetBytes, dir.string());
    ASSERT_TRUE(cache.ok());
    (*cache)->Keep(0, 0, "k", Atlas(64, 1.0f), {});
    EXPECT_EQ((*cache)->size(), 1u);
    // Unlinked at creation: the directory is empty while the cache is in use.
    EXPECT_TRUE(std::filesystem::is_empty(dir));
  }
  const auto missing = ResampledAtlasCache::Create(1000, (dir / "missing").string());
  EXPECT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("missing"), std::string::npos) << missing.status();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mvbrdf::pipeline
