#include "core/base/vector_exp.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace mvbrdf::base {
namespace {

// Distance in units in the last place between two finite positive doubles.
int64_t Ulps(double a, double b) {
  int64_t ia, ib;
  std::memcpy(&ia, &a, sizeof(a));
  std::memcpy(&ib, &b, sizeof(b));
  return ia > ib ? ia - ib : ib - ia;
}

// ExpAffine through each lane width this CPU runs (2 always).
std::vector<int> LaneWidths() {
  std::vector<int> widths;
  for (int lanes : {2, 4, 8}) {
    if (ExpAffineWithLanes(lanes, 0, 1.0, nullptr, nullptr, nullptr)) widths.push_back(lanes);
  }
  return widths;
}

TEST(ExpAffineTest, EveryLaneWidthWithinTwoUlpOfStdExpOverTheNormalRange) {
  EXPECT_FALSE(ExpAffineWithLanes(3, 0, 1.0, nullptr, nullptr, nullptr));
  ASSERT_FALSE(LaneWidths().empty());
  for (int lanes : LaneWidths()) {
    SCOPED_TRACE(lanes);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> wide(kExpFlushBelow, 709.7), narrow(-2.0, 2.0);
    std::vector<double> x(200003), y(x.size());
    for (size_t i = 0; i < x.size(); ++i) x[i] = i % 2 == 0 ? wide(rng) : narrow(rng);
    ASSERT_TRUE(ExpAffineWithLanes(lanes, x.size(), 1.0, x.data(), nullptr, y.data()));
    int64_t worst = 0;
    for (size_t i = 0; i < x.size(); ++i) {
      const double expected = std::exp(x[i]);
      ASSERT_TRUE(std::isnormal(y[i])) << x[i];
      worst = std::max(worst, Ulps(y[i], expected));
    }
    EXPECT_LE(worst, 2);
  }
}

TEST(ExpAffineTest, ScaleAndOffsetAreApplied) {
  const std::vector<double> x = {-0.5, -0.01, 0.0, -3.0, -0.2};
  const std::vector<double> offset = {0.1, -2.0, 0.0, 1.5, -0.7};
  std::vector<double> y(x.size());
  ExpAffine(x.size(), 40.0, x.data(), offset.data(), y.data());
  // The exponent scale * x + offset may be one fused multiply-add (AVX2): its
  // rounding differs by up to an ulp of 40 |x|, i.e. ~3e-15 relative here.
  for (size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(y[i], std::exp(40.0 * x[i] + offset[i]), 1e-14 * y[i]);
  // Aliasing the output with the input.
  std::vector<double> in_place = x;
  ExpAffine(in_place.size(), 40.0, in_place.data(), offset.data(), in_place.data());
  EXPECT_EQ(in_place, y);
}

TEST(ExpAffineTest, EdgesFlushOverflowAndNan) {
  for (int lanes : LaneWidths()) {
    SCOPED_TRACE(lanes);
    const double inf = std::numeric_limits<double>::infinity();
    const std::vector<double> x = {
        -inf, -1e300, -708.5, kExpFlushBelow - 1e-9, kExpFlushBelow, 709.78, 710.0, inf, std::nan(""), 0.0, -745.2};
    std::vector<double> y(x.size());
    ASSERT_TRUE(ExpAffineWithLanes(lanes, x.size(), 1.0, x.data(), nullptr, y.data()));
    EXPECT_EQ(y[0], 0.0);
    EXPECT_EQ(y[1], 0.0);
    EXPECT_EQ(y[2], 0.0);
    EXPECT_EQ(y[3], 0.0);
    EXPECT_LE(Ulps(y[4], std::exp(kExpFlushBelow)), 2);
    EXPECT_LE(Ulps(y[5], std::exp(709.78)), 2);
    EXPECT_EQ(y[6], inf);
    EXPECT_EQ(y[7], inf);
    EXPECT_TRUE(std::isnan(y[8]));
    EXPECT_EQ(y[9], 1.0);
    EXPECT_EQ(y[10], 0.0);
  }
}

TEST(ExpAffineTest, EveryTailLength) {
  for (int lanes : LaneWidths()) {
    for (size_t n = 0; n <= 17; ++n) {
      std::vector<double> x(n), y(n + 1, -1.0);
      for (size_t i = 0; i < n; ++i) x[i] = -0.3 * static_cast<double>(i);
      ASSERT_TRUE(ExpAffineWithLanes(lanes, n, 2.0, x.data(), nullptr, y.data()));
      for (size_t i = 0; i < n; ++i) EXPECT_LE(Ulps(y[i], std::exp(2.0 * x[i])), 2) << lanes << " " << n << " " << i;
      EXPECT_EQ(y[n], -1.0) << "wrote past the end at n = " << n << ", lanes " << lanes;
    }
  }
}

}  // namespace
}  // namespace mvbrdf::base
