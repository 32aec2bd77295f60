#include "core/pipeline/shadow_atlas_cache.h"

#include <gtest/gtest.h>

namespace mvbrdf::pipeline {
namespace {

cv::Mat Atlas(int channels, uint16_t value) {
  cv::Mat atlas(64, 64, CV_16UC(channels), cv::Scalar::all(0));
  for (int y = 10; y < 40; ++y) {
    for (int x = 5; x < 50; ++x) atlas.ptr<uint16_t>(y)[x * channels] = static_cast<uint16_t>(value + x);
  }
  return atlas;
}

TEST(ShadowAtlasCacheTest, GivesBackTheAtlasKeptBitForBit) {
  ShadowAtlasCache cache;
  EXPECT_FALSE(cache.Find(3, "L").has_value());
  for (int channels : {1, 2, 5}) {
    const cv::Mat atlas = Atlas(channels, static_cast<uint16_t>(100 * channels));
    cache.Keep(channels, "L", atlas);
    const std::optional<cv::Mat> kept = cache.Find(channels, "L");
    ASSERT_TRUE(kept.has_value());
    EXPECT_EQ(kept->type(), atlas.type());
    EXPECT_EQ(kept->size(), atlas.size());
    EXPECT_EQ(cv::norm(*kept, atlas, cv::NORM_INF), 0.0);
  }
  EXPECT_EQ(cache.size(), 3u);
  // Other lights (refined between passes): not this atlas.
  EXPECT_FALSE(cache.Find(1, "M").has_value());
  // Compressed: far below the 8 KB of a one-channel atlas.
  EXPECT_LT(cache.bytes(), 3u * 2048u);
}

TEST(ShadowAtlasCacheTest, KeepsNothingBeyondTheBudget) {
  ShadowAtlasCache cache(16);
  cache.Keep(0, "L", Atlas(1, 7));
  EXPECT_EQ(cache.size(), 0u);
  EXPECT_FALSE(cache.Find(0, "L").has_value());
}

}  // namespace
}  // namespace mvbrdf::pipeline
