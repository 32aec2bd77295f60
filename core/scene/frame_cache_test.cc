#include "core/scene/frame_cache.h"

#include <gtest/gtest.h>

namespace mvbrdf::scene {
namespace {

FramePositions Positions(size_t n, float value) { return FramePositions(n, glm::vec3(value)); }

TEST(FrameCacheTest, KeepsFramesWhileTheyFitTheBudget) {
  // Two frames of 10 vertices (120 bytes + a 2-byte key each) fit 250 bytes; a third does not.
  FrameCache cache(250);
  EXPECT_FALSE(cache.Find("f0").has_value());
  cache.Keep("f0", Positions(10, 1.0f));
  cache.Keep("f1", Positions(10, 2.0f));
  cache.Keep("f2", Positions(10, 3.0f));
  EXPECT_EQ(cache.size(), 2u);
  EXPECT_EQ(cache.bytes(), 244u);
  ASSERT_TRUE(cache.Find("f1").has_value());
  EXPECT_EQ((*cache.Find("f1"))[9], glm::vec3(2.0f));
  EXPECT_FALSE(cache.Find("f2").has_value());
  // The first kept stays: a second Keep under the same key changes nothing.
  cache.Keep("f0", Positions(10, 9.0f));
  EXPECT_EQ((*cache.Find("f0"))[0], glm::vec3(1.0f));
}

TEST(FrameCacheTest, AZeroBudgetKeepsNothing) {
  FrameCache cache(0);
  cache.Keep("f0", Positions(1, 1.0f));
  EXPECT_EQ(cache.size(), 0u);
}

}  // namespace
}  // namespace mvbrdf::scene
