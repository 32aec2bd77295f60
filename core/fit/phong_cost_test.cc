#include "core/fit/phong_cost.h"

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "ceres/gradient_checker.h"
#include "gtest/gtest.h"

namespace mvbrdf::fit::internal {
namespace {

// Hand-computed values are exact to about 1e-16; allow a few ulps.
constexpr double kHandTolerance = 1e-14;
// GradientChecker: relative error between the analytic and the central
// numeric Jacobian.
constexpr double kGradientTolerance = 1e-6;

// One sample, two lights with weights 1 and 0.5, g = (0.5, 0.8),
// h = (0.9, 0), r = 0.7 at a = 0.4, b = 0.2, ke = 10:
//   G   = 1 * 0.5 + 0.5 * 0.8                 = 0.9
//   S   = 1 * 0.9^10                          = 0.3486784401
//   rho = 0.7 - (0.4 * 0.9 + 0.2 * 0.3486784401) = 0.27026431198
//   J   = (-G, -S, -b * 0.9^10 * ln 0.9 * 10) = (-0.9, -0.3486784401, 0.073473880495405)
TEST(PhongCostTest, HandComputedResidualAndJacobian) {
  const std::vector<double> log_h = {std::log(0.9), kNoHighlight};
  PhongTerms terms;
  terms.AddDense(2, log_h.data());
  EXPECT_EQ(terms.slot, std::vector<uint16_t>{0});  // h = 0: no term
  PhongChannelData data;
  terms.Attach(&data);
  data.weight = {1.0, 0.5};
  data.r = {0.7};
  data.diffuse = {1.0 * 0.5 + 0.5 * 0.8};
  const std::unique_ptr<ceres::CostFunction> cost(PhongBlockCost::Create(&data, 0, 1));
  ASSERT_EQ(cost->num_residuals(), 1);
  ASSERT_EQ(cost->parameter_block_sizes(), std::vector<int32_t>{3});

  const double x[3] = {0.4, 0.2, std::log(10.0)};
  const double* parameters[] = {x};
  double residual = 0.0, jacobian[3];
  double* jacobians[] = {jacobian};
  ASSERT_TRUE(cost->Evaluate(parameters, &residual, jacobians));
  EXPECT_NEAR(residual, 0.27026431198, kHandTolerance);
  EXPECT_NEAR(jacobian[0], -0.9, kHandTolerance);
  EXPECT_NEAR(jacobian[1], -0.3486784401, kHandTolerance);
  EXPECT_NEAR(jacobian[2], 0.073473880495405, kHandTolerance);
  EXPECT_NEAR(PhongCost(data, x), 0.5 * 0.27026431198 * 0.27026431198, kHandTolerance);
}

// Random data with highlight cosines in (1 - spread, 1): a quarter without
// highlight (h = 0) and one exact mirror (h = 1).
struct RandomData {
  std::vector<double> log_h;
  PhongTerms terms;
  PhongChannelData data;
};

std::unique_ptr<RandomData> MakeRandomData(double spread, uint64_t seed) {
  auto random = std::make_unique<RandomData>();
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  constexpr int kLights = 3;
  constexpr size_t kSamples = 50;
  PhongChannelData& data = random->data;
  data.weight = {1.0, 0.3, 0.7};
  for (size_t i = 0; i < kSamples; ++i) {
    double g = 0.0;
    for (int k = 0; k < kLights; ++k) {
      const double u = uniform(rng);
      random->log_h.push_back(u < 0.25 ? kNoHighlight : (i == 3 && k == 0 ? 0.0 : std::log1p(-spread * u)));
      g += data.weight[k] * uniform(rng);
    }
    random->terms.AddDense(kLights, random->log_h.data() + i * kLights);
    data.diffuse.push_back(g);
    data.r.push_back(uniform(rng));
  }
  random->terms.Attach(&data);
  return random;
}

// Probed where the terms are not negligible: central differences of a
// residual of order 1 cannot resolve derivatives below ~1e-12, which the
// relative error of GradientChecker then reports as wrong (spread ~ 5 / ke
// keeps h^ke above e^-5).
TEST(PhongCostTest, GradientCheckerAgreesWithAnalyticJacobian) {
  struct Probe {
    double a, b, ke, spread;
  };
  for (const Probe& probe : {Probe{0.4, 0.2, 10.0, 0.1}, Probe{1.0, 0.0, 3.0, 0.5}, Probe{0.0, 2.0, 1.0, 0.9},
                             Probe{0.3, 0.5, 1e3, 5e-3}, Probe{0.3, 0.5, 1e4, 5e-4}}) {
    const std::unique_ptr<RandomData> random = MakeRandomData(probe.spread, 7);
    // A block that does not start at sample 0.
    const std::unique_ptr<ceres::CostFunction> cost(PhongBlockCost::Create(&random->data, 5, random->data.size()));
    const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
    ceres::GradientChecker checker(cost.get(), no_manifolds, ceres::NumericDiffOptions());
    const double x[3] = {probe.a, probe.b, std::log(probe.ke)};
    const double* parameters[] = {x};
    ceres::GradientChecker::ProbeResults results;
    EXPECT_TRUE(checker.Probe(parameters, kGradientTolerance, &results))
        << "at a " << probe.a << ", b " << probe.b << ", ke " << probe.ke << ": " << results.error_log;
  }
}

// Far beyond the lobe (ke = 1e4, h = 0.5) every term underflows to exactly 0.
TEST(PhongCostTest, HugeExponentUnderflowsCleanly) {
  const std::vector<double> log_h = {std::log(0.5)};
  PhongTerms terms;
  terms.AddDense(1, log_h.data());
  PhongChannelData data;
  terms.Attach(&data);
  data.weight = {1.0};
  data.r = {0.25};
  data.diffuse = {0.5};
  const double x[3] = {0.5, 1.0, std::log(1e4)};
  double residual, jacobian[3];
  EvaluatePhongResiduals(data, 0, 1, x, &residual, jacobian);
  EXPECT_EQ(residual, 0.0);
  EXPECT_EQ(jacobian[1], 0.0);
  EXPECT_EQ(jacobian[2], 0.0);
}

// SpecularSumsRange against the sums written out with std::exp, from the CSR
// terms and from the dense layout, with fall-off (one ln a of -inf: a = 0),
// unequal weights, samples without a term, exponents past the underflow,
// and ranges across its 512-sample blocks.
TEST(PhongCostTest, SpecularSumsRangeDenseAndSparseMatchTheSums) {
  constexpr int kSlots = 3;
  constexpr size_t kSamples = 1500;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> cosine(0.0, 1.0), falloff(-2.0, 0.5);
  PhongTerms terms;
  std::vector<double> row_h(kSlots), row_a(kSlots);
  for (size_t i = 0; i < kSamples; ++i) {
    for (int k = 0; k < kSlots; ++k) {
      const double h = cosine(rng);
      row_h[k] = h < 0.3 ? kNoHighlight : std::log(h);  // ~30 % without a term
      row_a[k] = i == 7 && k == 1 ? kNoHighlight : falloff(rng);
    }
    terms.AddDense(kSlots, row_h.data(), row_a.data());
  }
  PhongTerms dense = terms;
  dense.Densify(kSlots);
  ASSERT_EQ(dense.dense_slots, kSlots);  // 3 x 1500 entries <= 2 x ~3150 terms
  PhongChannelData sparse_data, dense_data;
  terms.Attach(&sparse_data);
  dense.Attach(&dense_data);
  for (PhongChannelData* data : {&sparse_data, &dense_data}) {
    data->weight = {1.0, 0.25, 0.6};
    data->r.assign(kSamples, 0.0);
  }
  for (double ke : {3.0, 40.0, 2000.0}) {
    for (const auto& [begin, end] : std::vector<std::pair<size_t, size_t>>{{0, kSamples}, {5, 1030}, {700, 701}}) {
      std::vector<double> s_sparse(end - begin), d_sparse(end - begin), s_dense(end - begin), d_dense(end - begin);
      SpecularSumsRange(sparse_data, begin, end, ke, s_sparse.data(), d_sparse.data());
      SpecularSumsRange(dense_data, begin, end, ke, s_dense.data(), d_dense.data());
      for (size_t i = begin; i < end; ++i) {
        double s = 0.0, d = 0.0;
        for (uint64_t j = terms.begin[i]; j < terms.begin[i + 1]; ++j) {
          const double e = ke * terms.log_h[j] + terms.log_a[j];
          if (e < kExpUnderflow) continue;
          const double p = sparse_data.weight[terms.slot[j]] * std::exp(e);
          s += p;
          d += p * terms.log_h[j];
        }
        const size_t at = i - begin;
        ASSERT_TRUE(std::isfinite(s_sparse[at]) && std::isfinite(d_sparse[at])) << i;
        // The exponent ke ln h + ln a (up to ~700) is rounded once (a fused
        // multiply-add) or twice (here): ~1e-13 relative in exp at the most.
        EXPECT_NEAR(s_sparse[at], s, 4e-13 * std::fabs(s)) << ke << " " << i;
        EXPECT_NEAR(d_sparse[at], d, 4e-13 * std::fabs(d)) << ke << " " << i;
        // The dense layout adds the same terms in the same order (and zeros).
        EXPECT_EQ(s_dense[at], s_sparse[at]) << ke << " " << i;
        EXPECT_EQ(d_dense[at], d_sparse[at]) << ke << " " << i;
      }
      // S alone (d null) is the same S.
      std::vector<double> s_only(end - begin);
      SpecularSumsRange(dense_data, begin, end, ke, s_only.data(), nullptr);
      EXPECT_EQ(s_only, s_dense);
    }
  }
  // A term of ln h = -inf written directly (AddDense leaves it out) adds 0 to
  // S and D in both layouts, not NaN.
  PhongTerms odd;
  odd.slot = {0, 1};
  odd.log_h = {kNoHighlight, -0.5};
  odd.begin = {0, 2};
  PhongTerms odd_dense = odd;
  odd_dense.Densify(2);
  ASSERT_EQ(odd_dense.dense_slots, 2);
  for (const PhongTerms* t : {&odd, &odd_dense}) {
    PhongChannelData data;
    t->Attach(&data);
    data.weight = {1.0, 1.0};
    data.r = {0.0};
    double s = -1.0, d = -1.0;
    SpecularSumsRange(data, 0, 1, 10.0, &s, &d);
    EXPECT_NEAR(s, std::exp(-5.0), 1e-15) << (t == &odd ? "csr" : "dense");
    EXPECT_NEAR(d, -0.5 * std::exp(-5.0), 1e-15) << (t == &odd ? "csr" : "dense");
  }
  // Sparse data (OLAT-like: one of many slots per sample) stays in CSR form.
  PhongTerms olat;
  std::vector<double> row(96, kNoHighlight);
  for (size_t i = 0; i < 100; ++i) {
    std::fill(row.begin(), row.end(), kNoHighlight);
    row[i % 96] = -0.1;
    olat.AddDense(96, row.data());
  }
  olat.Densify(96);
  EXPECT_EQ(olat.dense_slots, 0);
}

}  // namespace
}  // namespace mvbrdf::fit::internal
