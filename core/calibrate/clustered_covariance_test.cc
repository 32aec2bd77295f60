#include "core/calibrate/clustered_covariance.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace mvbrdf::calibrate {
namespace {

// y = a_c + b x: an intercept per cluster (a nuisance) and one slope.
struct Line {
  double x, y;
  template <typename T>
  bool operator()(const T* a, const T* b, T* r) const {
    r[0] = a[0] + b[0] * x - y;
    return true;
  }
};

struct Fit {
  double slope = 0, sandwich_sigma = 0, naive_sigma = 0;
  absl::StatusCode code = absl::StatusCode::kOk;
};

// G clusters of n points whose errors share a random slope per cluster
// (sd `shared`) besides independent noise (sd `noise`): correlated inside a
// cluster in a way the intercepts do not absorb.
Fit FitOnce(std::mt19937& rng, int clusters, int n, double shared, double noise) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<double> a(static_cast<size_t>(clusters), 0.0);
  double b = 0;
  ceres::Problem problem;
  std::vector<std::vector<ceres::ResidualBlockId>> ids(static_cast<size_t>(clusters));
  for (int c = 0; c < clusters; ++c) {
    const double u = shared * gauss(rng), offset = 3.0 * gauss(rng);
    for (int i = 0; i < n; ++i) {
      const double x = -1.0 + 2.0 * i / (n - 1.0);
      const double y = offset + 0.5 * x + u * x + noise * gauss(rng);
      ids[static_cast<size_t>(c)].push_back(problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<Line, 1, 1, 1>(new Line{x, y}), nullptr, &a[static_cast<size_t>(c)], &b));
    }
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  Fit fit;
  fit.slope = b;
  // What Ceres's covariance scaled by the residual variance says.
  ceres::Covariance covariance(ceres::Covariance::Options{});
  const std::vector<std::pair<const double*, const double*>> blocks = {{&b, &b}};
  double cb = 0;
  if (covariance.Compute(blocks, &problem) && covariance.GetCovarianceBlock(&b, &b, &cb)) {
    fit.naive_sigma = std::sqrt(cb * 2.0 * summary.final_cost / (clusters * n - clusters - 1.0));
  }
  const absl::StatusOr<ClusteredCovarianceResult> c = ClusteredCovariance(problem, {&b}, ids);
  fit.code = c.status().code();
  if (c.ok()) fit.sandwich_sigma = std::sqrt(c->covariance(0, 0));
  return fit;
}

TEST(ClusteredCovarianceTest, MatchesTheSpreadOfCorrelatedResidualsWhereTheNaiveOneIsTooSmall) {
  std::mt19937 rng(7);
  const int trials = 300;
  double sum = 0, sum2 = 0, sandwich = 0, naive = 0;
  for (int t = 0; t < trials; ++t) {
    const Fit fit = FitOnce(rng, 40, 25, 0.2, 0.05);
    ASSERT_EQ(fit.code, absl::StatusCode::kOk);
    sum += fit.slope;
    sum2 += fit.slope * fit.slope;
    sandwich += fit.sandwich_sigma / trials;
    naive += fit.naive_sigma / trials;
  }
  const double spread = std::sqrt(sum2 / trials - std::pow(sum / trials, 2));
  // The slope's actual spread is 0.2 / sqrt(40) ~ 0.032.
  EXPECT_NEAR(sandwich / spread, 1.0, 0.15) << "sandwich " << sandwich << " spread " << spread;
  EXPECT_LT(naive / spread, 0.5) << "naive " << naive << " spread " << spread;
}

TEST(ClusteredCovarianceTest, IndependentResidualsGiveTheUsualCovariance) {
  std::mt19937 rng(11);
  const Fit fit = FitOnce(rng, 60, 20, 0.0, 0.1);
  ASSERT_EQ(fit.code, absl::StatusCode::kOk);
  EXPECT_NEAR(fit.sandwich_sigma / fit.naive_sigma, 1.0, 0.2);
}

TEST(ClusteredCovarianceTest, RefusesSharedNuisancesTooFewClustersAndUnidentifiedInterest) {
  double a = 0, b = 0, c = 0;
  ceres::Problem problem;
  std::vector<ceres::ResidualBlockId> ids;
  for (int i = 0; i < 4; ++i) {
    ids.push_back(problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Line, 1, 1, 1>(new Line{i * 1.0, i * 2.0}),
                                           nullptr, &a, &b));
  }
  // `a` is in both clusters and not of interest.
  EXPECT_EQ(ClusteredCovariance(problem, {&b}, {{ids[0], ids[1]}, {ids[2], ids[3]}}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ClusteredCovariance(problem, {&a, &b}, {ids}).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(ClusteredCovariance(problem, {&a, &b}, {{ids[0], ids[1]}, {ids[2], ids[3]}}).ok());
  // c only ever appears with x = 0: no information on it.
  const ceres::ResidualBlockId flat =
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Line, 1, 1, 1>(new Line{0.0, 1.0}), nullptr, &a, &c);
  EXPECT_EQ(ClusteredCovariance(problem, {&a, &b, &c}, {{ids[0], ids[1]}, {ids[2], ids[3], flat}}).status().code(),
            absl::StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace mvbrdf::calibrate
