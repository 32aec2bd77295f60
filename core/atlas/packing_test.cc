#include "core/atlas/packing.h"

#include <gtest/gtest.h>

#include <cmath>

namespace mvbrdf::atlas::internal {
namespace {

constexpr double kTolerance = 1e-9;

TEST(MinAreaRectangleTest, RecoversARotatedRectangle) {
  // A 4 x 1 rectangle turned by 30 degrees, plus interior points.
  const double c = std::cos(0.5235987755982988), s = std::sin(0.5235987755982988);
  std::vector<glm::dvec2> points;
  for (const glm::dvec2& q : {glm::dvec2(0, 0), glm::dvec2(4, 0), glm::dvec2(4, 1), glm::dvec2(0, 1),
                              glm::dvec2(2, 0.5), glm::dvec2(1, 0.2)}) {
    points.emplace_back(c * q.x - s * q.y + 3.0, s * q.x + c * q.y - 1.0);
  }
  const OrientedRect rect = MinAreaRectangle(points);
  EXPECT_NEAR(rect.extent.x, 4.0, kTolerance);
  EXPECT_NEAR(rect.extent.y, 1.0, kTolerance);
  // A rotation (orientation kept) and every point inside the box.
  EXPECT_NEAR(rect.axis_x.x * rect.axis_y.y - rect.axis_x.y * rect.axis_y.x, 1.0, kTolerance);
  for (const glm::dvec2& p : points) {
    const glm::dvec2 q = rect.RectFromPlane(p);
    EXPECT_GE(q.x, -kTolerance);
    EXPECT_GE(q.y, -kTolerance);
    EXPECT_LE(q.x, rect.extent.x + kTolerance);
    EXPECT_LE(q.y, rect.extent.y + kTolerance);
  }
}

TEST(MinAreaRectangleTest, PortraitIsTurnedToLandscape) {
  const OrientedRect rect = MinAreaRectangle({{0, 0}, {1, 0}, {1, 3}, {0, 3}});
  EXPECT_NEAR(rect.extent.x, 3.0, kTolerance);
  EXPECT_NEAR(rect.extent.y, 1.0, kTolerance);
  const glm::dvec2 q = rect.RectFromPlane({1, 3});
  EXPECT_GE(q.x, -kTolerance);
  EXPECT_GE(q.y, -kTolerance);
  EXPECT_NEAR(rect.axis_x.x * rect.axis_y.y - rect.axis_x.y * rect.axis_y.x, 1.0, kTolerance);
}

TEST(PackRectanglesTest, BoxesKeepTheGutterAndFit) {
  std::vector<glm::dvec2> extents;
  for (int i = 0; i < 40; ++i) extents.emplace_back(1.0 + 0.1 * (i % 7), 0.5 + 0.05 * (i % 5));
  const int size = 128, gutter = 3;
  auto layout = PackRectangles(extents, size, gutter);
  ASSERT_TRUE(layout.ok()) << layout.status();
  const double s = layout->texels_per_unit;
  EXPECT_GT(s, 0.0);
  // Boxes [offset, offset + ceil(s extent)) grown by the gutter on every side
  // stay disjoint from each other's boxes and inside the atlas.
  for (size_t i = 0; i < extents.size(); ++i) {
    const glm::ivec2 lo = layout->offsets[i];
    const glm::ivec2 hi = lo + glm::ivec2(std::ceil(s * extents[i].x), std::ceil(s * extents[i].y));
    EXPECT_GE(lo.x, gutter);
    EXPECT_GE(lo.y, gutter);
    EXPECT_LE(hi.x, size - gutter);
    EXPECT_LE(hi.y, size - gutter);
    for (size_t j = 0; j < i; ++j) {
      const glm::ivec2 lo2 = layout->offsets[j];
      const glm::ivec2 hi2 = lo2 + glm::ivec2(std::ceil(s * extents[j].x), std::ceil(s * extents[j].y));
      const bool apart =
          hi.x + gutter <= lo2.x || hi2.x + gutter <= lo.x || hi.y + gutter <= lo2.y || hi2.y + gutter <= lo.y;
      EXPECT_TRUE(apart) << i << " and " << j;
    }
  }
  // Sanity on efficiency: the content uses a fair share of the atlas.
  double content = 0.0;
  for (const glm::dvec2& e : extents) content += s * s * e.x * e.y;
  EXPECT_GT(content / (size * size), 0.4);
}

TEST(PackRectanglesTest, TooManyBoxesIsResourceExhausted) {
  const std::vector<glm::dvec2> extents(100, glm::dvec2(1.0, 1.0));
  // 100 boxes of at least 1 + 2 texels need 30 x 30 > 16 x 16.
  EXPECT_EQ(PackRectangles(extents, 16, 2).status().code(), absl::StatusCode::kResourceExhausted);
}

}  // namespace
}  // namespace mvbrdf::atlas::internal
