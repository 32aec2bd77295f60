#include "core/fit/powell.h"

#include <algorithm>
#include <cmath>

#include "gtest/gtest.h"

namespace mvbrdf::fit {
namespace {

constexpr double kMinimumTolerance = 1e-6;

TEST(PowellTest, MinimisesRosenbrock) {
  const auto rosenbrock = [](const double* x) {
    return 100.0 * (x[1] - x[0] * x[0]) * (x[1] - x[0] * x[0]) + (1.0 - x[0]) * (1.0 - x[0]);
  };
  double x[2] = {-1.2, 1.0};
  PowellOptions options;
  options.function_tolerance = 1e-14;
  const PowellSummary summary = MinimizePowell(rosenbrock, 2, x, options);
  EXPECT_TRUE(summary.converged);
  EXPECT_NEAR(x[0], 1.0, kMinimumTolerance);
  EXPECT_NEAR(x[1], 1.0, kMinimumTolerance);
  EXPECT_LT(summary.final_cost, 1e-12);
  EXPECT_GT(summary.function_evaluations, 0);
}

// Restarts run after convergence (at least one more iteration, counted),
// never end worse, and keep the first run's initial cost; with a loose
// tolerance on Rosenbrock's valley the first run stops short and a restart
// goes on down it.
TEST(PowellTest, RestartsContinueFromTheResult) {
  const auto rosenbrock = [](const double* x) {
    return 100.0 * (x[1] - x[0] * x[0]) * (x[1] - x[0] * x[0]) + (1.0 - x[0]) * (1.0 - x[0]);
  };
  PowellOptions options;
  options.function_tolerance = 1e-3;
  double once[2] = {-1.2, 1.0}, again[2] = {-1.2, 1.0};
  const PowellSummary first = MinimizePowell(rosenbrock, 2, once, options);
  options.restarts = 3;
  const PowellSummary restarted = MinimizePowell(rosenbrock, 2, again, options);
  EXPECT_GT(restarted.iterations, first.iterations);
  EXPECT_GT(restarted.function_evaluations, first.function_evaluations);
  EXPECT_LE(restarted.final_cost, first.final_cost);
  EXPECT_EQ(restarted.initial_cost, first.initial_cost);
  EXPECT_EQ(restarted.final_cost, rosenbrock(again));
}

TEST(PowellTest, MinimisesIllConditionedQuadraticWithCoupling) {
  const auto quadratic = [](const double* x) {
    const double a = x[0] - 1.0, b = x[1] + 2.0, c = x[2] - 3.0;
    return a * a + 1e3 * b * b + 10.0 * c * c + 5.0 * a * c;
  };
  double x[3] = {0.0, 0.0, 0.0};
  const PowellSummary summary = MinimizePowell(quadratic, 3, x, PowellOptions());
  EXPECT_TRUE(summary.converged);
  EXPECT_NEAR(x[0], 1.0, 1e-4);
  EXPECT_NEAR(x[1], -2.0, 1e-4);
  EXPECT_NEAR(x[2], 3.0, 1e-4);
}

// The clamped cost f(P(x)) with the minimiser outside the box ends on the bound.
TEST(PowellTest, ProjectedCostEndsOnBound) {
  const auto clamp = [](double v) { return std::clamp(v, 0.0, 2.0); };
  const auto cost = [&](const double* x) {
    const double a = clamp(x[0]) + 1.0, b = clamp(x[1]) - 1.0;
    return a * a + b * b;
  };
  double x[2] = {1.5, 1.5};
  const PowellSummary summary =
      MinimizePowell(cost, 2, x, PowellOptions(), [&](double* u) { u[0] = clamp(u[0]), u[1] = clamp(u[1]); });
  EXPECT_TRUE(summary.converged);
  EXPECT_EQ(x[0], 0.0);
  EXPECT_NEAR(x[1], 1.0, kMinimumTolerance);
  EXPECT_NEAR(summary.final_cost, 1.0, 1e-10);
}

TEST(PowellTest, ReportsNonConvergenceWithinIterationLimit) {
  const auto rosenbrock = [](const double* x) {
    return 100.0 * (x[1] - x[0] * x[0]) * (x[1] - x[0] * x[0]) + (1.0 - x[0]) * (1.0 - x[0]);
  };
  double x[2] = {-1.2, 1.0};
  PowellOptions options;
  options.max_iterations = 2;
  const PowellSummary summary = MinimizePowell(rosenbrock, 2, x, options);
  EXPECT_FALSE(summary.converged);
  EXPECT_EQ(summary.iterations, 2);
  EXPECT_LT(summary.final_cost, summary.initial_cost);
}

}  // namespace
}  // namespace mvbrdf::fit
