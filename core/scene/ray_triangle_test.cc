#include "core/scene/ray_triangle.h"

#include <gtest/gtest.h>

namespace mvbrdf::scene {
namespace {

TEST(IntersectRayTriangle, BarycentricWeightsAndDistance) {
  const glm::dvec3 p0(0.0, 0.0, 2.0), p1(1.0, 0.0, 2.0), p2(0.0, 1.0, 2.0);
  // The point 0.5 p0 + 0.2 p1 + 0.3 p2, reached from the origin at 2.5 x a direction.
  const glm::dvec3 target = 0.5 * p0 + 0.2 * p1 + 0.3 * p2;
  const auto hit = IntersectRayTriangle(glm::dvec3(0.0), target / 2.5, p0, p1, p2);
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->b1, 0.2, 1e-15);
  EXPECT_NEAR(hit->b2, 0.3, 1e-15);
  EXPECT_NEAR(hit->distance, 2.5, 1e-15);
  // Outside the triangle and behind the origin: reported, the caller decides.
  const auto outside = IntersectRayTriangle(glm::dvec3(0.0), -glm::dvec3(2.0, 2.0, 2.0), p0, p1, p2);
  ASSERT_TRUE(outside.has_value());
  EXPECT_NEAR(outside->b1 + outside->b2, 4.0, 1e-12);
  EXPECT_NEAR(outside->distance, -1.0, 1e-12);
  // Parallel to the plane: none.
  EXPECT_FALSE(IntersectRayTriangle(glm::dvec3(0.0), glm::dvec3(1.0, 0.0, 0.0), p0, p1, p2).has_value());
}

}  // namespace
}  // namespace mvbrdf::scene
