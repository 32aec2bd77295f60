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

// A right triangle with legs a (x) and b (y), in its rectangle's frame.
ChartShape RightTriangle(double a, double b) {
  ChartShape c;
  c.extent = glm::dvec2(a, b);
  c.triangles.push_back({glm::dvec2(0, 0), glm::dvec2(a, 0), glm::dvec2(0, b)});
  c.area = 0.5 * a * b;
  return c;
}

// An L of three unit squares (two triangles each) in a 2 x 2 box, scaled.
ChartShape Ell(double side) {
  ChartShape c;
  c.extent = glm::dvec2(2.0 * side);
  for (const glm::dvec2 o : {glm::dvec2(0, 0), glm::dvec2(1, 0), glm::dvec2(0, 1)}) {
    const glm::dvec2 a = side * o, b = side * (o + glm::dvec2(1, 0)), d = side * (o + glm::dvec2(0, 1)),
                     e = side * (o + glm::dvec2(1, 1));
    c.triangles.push_back({a, b, e});
    c.triangles.push_back({a, e, d});
    c.area += side * side;
  }
  return c;
}

// Every placed chart's texels, found independently of the packer: points on
// a fine barycentric grid of each triangle, mapped by Place, marked in the
// texel under them. Checks boxes inside the border, orientation kept and no
// two charts' texels within the gutter (Chebyshev); returns the fraction of
// the atlas marked.
double ExpectLayoutKeepsTheGutter(const std::vector<ChartShape>& charts, const PackedLayout& layout, int size,
                                  int gutter) {
  std::vector<int> owner(static_cast<size_t>(size) * size, -1);
  int64_t marked = 0;
  for (size_t c = 0; c < charts.size(); ++c) {
    for (const auto& tri : charts[c].triangles) {
      const glm::dvec2 p0 = layout.Place(c, charts[c].extent, tri[0]), p1 = layout.Place(c, charts[c].extent, tri[1]),
                       p2 = layout.Place(c, charts[c].extent, tri[2]);
      const double before =
          (tri[1].x - tri[0].x) * (tri[2].y - tri[0].y) - (tri[1].y - tri[0].y) * (tri[2].x - tri[0].x);
      const double after = (p1.x - p0.x) * (p2.y - p0.y) - (p1.y - p0.y) * (p2.x - p0.x);
      EXPECT_NEAR(after, before * layout.texels_per_unit * layout.texels_per_unit, 1e-6 * (1.0 + std::abs(after)));
      constexpr int kSteps = 64;
      for (int a = 0; a <= kSteps; ++a) {
        for (int b = 0; a + b <= kSteps; ++b) {
          // Nudged towards the centroid: a vertex exactly on a texel
          // boundary belongs to the texel inside the box.
          const glm::dvec2 centroid = (p0 + p1 + p2) / 3.0;
          glm::dvec2 p = p0 + (p1 - p0) * (a / double(kSteps)) + (p2 - p0) * (b / double(kSteps));
          p += 1e-9 * (centroid - p);
          const int i = static_cast<int>(std::floor(p.x)), j = static_cast<int>(std::floor(p.y));
          EXPECT_GE(i, gutter);
          EXPECT_GE(j, gutter);
          EXPECT_LT(i, size - gutter);
          EXPECT_LT(j, size - gutter);
          if (i < 0 || j < 0 || i >= size || j >= size) continue;
          int& o = owner[static_cast<size_t>(j) * size + i];
          if (o < 0) ++marked;
          o = static_cast<int>(c);
        }
      }
    }
  }
  int64_t violations = 0;
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      const int c = owner[static_cast<size_t>(j) * size + i];
      if (c < 0) continue;
      for (int dj = -gutter; dj <= gutter; ++dj) {
        for (int di = -gutter; di <= gutter; ++di) {
          const int ii = i + di, jj = j + dj;
          if (ii < 0 || jj < 0 || ii >= size || jj >= size) continue;
          const int other = owner[static_cast<size_t>(jj) * size + ii];
          if (other >= 0 && other != c) ++violations;
        }
      }
    }
  }
  EXPECT_EQ(violations, 0) << "texels of different charts within the gutter";
  return static_cast<double>(marked) / (static_cast<double>(size) * size);
}

TEST(PackChartsTest, OutlinesKeepTheGutterAndFit) {
  std::vector<ChartShape> charts;
  for (int i = 0; i < 30; ++i) {
    charts.push_back(i % 3 == 0 ? Ell(0.3 + 0.05 * (i % 4)) : RightTriangle(1.0 + 0.1 * (i % 7), 0.5 + 0.05 * (i % 5)));
  }
  const int size = 128, gutter = 2;
  auto layout = PackCharts(charts, size, gutter);
  ASSERT_TRUE(layout.ok()) << layout.status();
  EXPECT_GT(layout->texels_per_unit, 0.0);
  const double covered = ExpectLayoutKeepsTheGutter(charts, *layout, size, gutter);
  // The charts fill 0.56 of their rectangles; their outlines fill more than
  // half the atlas with a gutter of 2 (measured 0.523 of the texels marked).
  EXPECT_GT(covered, 0.5);
  for (int turn : layout->turns) {
    EXPECT_GE(turn, 0);
    EXPECT_LT(turn, 4);
  }
}

TEST(PackChartsTest, TwoTrianglesNestInOneSquare) {
  // Two right triangles with unit legs: as rectangles, two unit boxes side by
  // side (scale <= (64 - 3 gutters) / 2 = 30.5); as outlines, the second turns
  // by a half turn into the first's empty half.
  const std::vector<ChartShape> charts = {RightTriangle(1.0, 1.0), RightTriangle(1.0, 1.0)};
  const int size = 64, gutter = 1;
  auto layout = PackCharts(charts, size, gutter);
  ASSERT_TRUE(layout.ok()) << layout.status();
  ExpectLayoutKeepsTheGutter(charts, *layout, size, gutter);
  EXPECT_GT(layout->texels_per_unit, 45.0);
  EXPECT_EQ(layout->turns[0], 0);
  EXPECT_EQ(layout->turns[1], 2);
}

TEST(PackChartsTest, TooManyChartsIsResourceExhausted) {
  // 100 charts of at least 1 + 2 texels need 30 x 30 > 16 x 16.
  const std::vector<ChartShape> charts(100, RightTriangle(1.0, 1.0));
  EXPECT_EQ(PackCharts(charts, 16, 2).status().code(), absl::StatusCode::kResourceExhausted);
}

}  // namespace
}  // namespace mvbrdf::atlas::internal
