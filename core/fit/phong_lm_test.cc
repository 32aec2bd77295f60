#include "core/fit/phong_lm.h"

#include <cmath>
#include <random>
#include <vector>

#include "ceres/ceres.h"
#include "gtest/gtest.h"

namespace mvbrdf::fit::internal {
namespace {

// n samples of 4 lights (weights 1, 0.8, 0.6, 0.4) drawn from the model at
// (a, b, ke) with relative noise; a fifth of the terms without highlight.
struct Problem {
  PhongTerms terms;
  PhongChannelData data;
};

std::unique_ptr<Problem> MakeProblem(size_t n, double a, double b, double ke, double noise, uint32_t seed,
                                     bool weighted = false) {
  auto p = std::make_unique<Problem>();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  p->data.weight = {1.0, 0.8, 0.6, 0.4};
  for (size_t i = 0; i < n; ++i) {
    double log_h[4];
    double g = 0.0, s = 0.0;
    for (int k = 0; k < 4; ++k) {
      const double cos_h = u(rng) < 0.2 ? 0.0 : 1.0 - 0.3 * u(rng) * u(rng);
      log_h[k] = cos_h > 0.0 ? std::log(cos_h) : kNoHighlight;
      g += p->data.weight[static_cast<size_t>(k)] * u(rng);
      if (cos_h > 0.0) s += p->data.weight[static_cast<size_t>(k)] * std::pow(cos_h, ke);
    }
    p->terms.AddDense(4, log_h);
    p->data.diffuse.push_back(g);
    p->data.r.push_back((a * g + b * s) * (1.0 + noise * gauss(rng)));
    if (weighted) p->data.sqrt_weight.push_back(0.5 + u(rng));
  }
  p->terms.Attach(&p->data);
  return p;
}

// What FitPhong ran before: Ceres's LM over analytic blocks of 1024.
double CeresCost(const PhongChannelData& data, const bool* free, const double* lower, const double* upper,
                 double* x) {
  ceres::Problem problem;
  for (size_t begin = 0; begin < data.size(); begin += 1024) {
    problem.AddResidualBlock(PhongBlockCost::Create(&data, begin, std::min(data.size(), begin + 1024)), nullptr, x);
  }
  std::vector<int> constant;
  for (int j = 0; j < 3; ++j) {
    if (!free[j]) constant.push_back(j);
  }
  if (!constant.empty()) problem.SetManifold(x, new ceres::SubsetManifold(3, constant));
  for (int j = 0; j < 3; ++j) {
    if (!free[j]) continue;
    problem.SetParameterLowerBound(x, j, lower[j]);
    problem.SetParameterUpperBound(x, j, upper[j]);
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  options.function_tolerance = 1e-10;
  options.parameter_tolerance = 1e-10;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  return summary.final_cost;
}

TEST(PhongLmTest, ReachesCeresCostAndTheTruthInFewPasses) {
  struct Case {
    double a, b, ke, noise;
    bool weighted;
  };
  for (const Case& c : {Case{0.5, 0.3, 40.0, 0.0, false}, Case{0.5, 0.3, 40.0, 0.05, false},
                        Case{0.2, 1.0, 1000.0, 0.02, false}, Case{0.8, 0.05, 5.0, 0.05, true}}) {
    SCOPED_TRACE(testing::Message() << "ke " << c.ke << " noise " << c.noise << " weighted " << c.weighted);
    const auto p = MakeProblem(20000, c.a, c.b, c.ke, c.noise, 3, c.weighted);
    const bool free[3] = {true, true, true};
    const double lower[3] = {0.0, 0.0, 0.0}, upper[3] = {10.0, 10.0, std::log(1e4)};
    double ours[3] = {0.3, 0.1, std::log(10.0)}, theirs[3] = {0.3, 0.1, std::log(10.0)};
    const PhongLmSummary s = SolvePhongLm(p->data, free, lower, upper, PhongLmOptions{}, ours);
    const double ceres_cost = CeresCost(p->data, free, lower, upper, theirs);
    EXPECT_TRUE(s.converged);
    EXPECT_LE(s.final_cost, ceres_cost * (1.0 + 1e-8) + 1e-300);
    EXPECT_NEAR(s.final_cost, PhongCost(p->data, ours), 1e-12 * (1.0 + s.final_cost));
    EXPECT_LE(s.passes, 40);
    if (c.noise == 0.0) {
      EXPECT_NEAR(ours[0], c.a, 1e-6);
      EXPECT_NEAR(ours[1], c.b, 1e-6);
      EXPECT_NEAR(std::exp(ours[2]), c.ke, 1e-4 * c.ke);
    }
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(ours[j], theirs[j], 1e-4 * (1.0 + std::abs(theirs[j]))) << j;
  }
}

TEST(PhongLmTest, HeldCoordinatesStayAndBoundsHold) {
  const auto p = MakeProblem(5000, 0.5, 0.3, 40.0, 0.01, 5);
  // kd held at a wrong value, ks bounded below its truth.
  const bool free[3] = {false, true, true};
  const double lower[3] = {0.0, 0.0, 0.0}, upper[3] = {10.0, 0.2, std::log(1e4)};
  double ours[3] = {0.45, 0.1, std::log(10.0)}, theirs[3] = {0.45, 0.1, std::log(10.0)};
  const PhongLmSummary s = SolvePhongLm(p->data, free, lower, upper, PhongLmOptions{}, ours);
  const double ceres_cost = CeresCost(p->data, free, lower, upper, theirs);
  EXPECT_TRUE(s.converged);
  EXPECT_EQ(ours[0], 0.45);
  EXPECT_EQ(ours[1], 0.2);  // at its upper bound
  EXPECT_LE(s.final_cost, ceres_cost * (1.0 + 1e-8));
  // Nothing free: no step, the cost at x.
  const bool none[3] = {false, false, false};
  double x[3] = {0.5, 0.3, std::log(40.0)};
  const PhongLmSummary held = SolvePhongLm(p->data, none, lower, upper, PhongLmOptions{}, x);
  EXPECT_EQ(held.iterations, 0);
  EXPECT_DOUBLE_EQ(held.final_cost, PhongCost(p->data, x));
}

TEST(PhongLmTest, StopsAtTheIterationLimitUnconverged) {
  const auto p = MakeProblem(2000, 0.5, 0.3, 40.0, 0.05, 9);
  const bool free[3] = {true, true, true};
  const double lower[3] = {0.0, 0.0, 0.0}, upper[3] = {10.0, 10.0, std::log(1e4)};
  double x[3] = {0.3, 0.1, std::log(1000.0)};
  PhongLmOptions options;
  options.max_iterations = 1;
  const PhongLmSummary s = SolvePhongLm(p->data, free, lower, upper, options, x);
  EXPECT_EQ(s.iterations, 1);
  EXPECT_FALSE(s.converged);
}

}  // namespace
}  // namespace mvbrdf::fit::internal
