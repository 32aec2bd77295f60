#include "core/fit/grazing_support.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "core/brdf/geometry.h"
#include "core/brdf/ggx.h"
#include "core/fit/fit_test_util.h"

namespace mvbrdf::fit {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRoughness = 0.2;

std::array<LobeChannel, 3> Lobe(double roughness = kRoughness) {
  LobeChannel c;
  c.kd = 0.2;
  c.p = {0.04, roughness, brdf::Ggx::kDielectricRatio};
  return {c, c, c};
}

// Samples of a surface point (n = +z), each seen at the mirror direction of
// its one light (n.h = 1: inside any lobe) at an angle from the normal drawn
// uniformly in [0, max_degrees], one light of two.
samples::SampleSet MirrorSamples(double max_degrees, int num_samples, bool half_vector = true) {
  samples::SampleSet set;
  set.half_vector = half_vector;
  set.light_names = {"L0", "L1"};
  set.light_intensity = {glm::vec3(1.0f), glm::vec3(1.0f)};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int i = 0; i < num_samples; ++i) {
    const double theta = max_degrees * kPi / 180.0 * unit(rng);
    const float c = static_cast<float>(std::cos(theta));
    const uint16_t light = static_cast<uint16_t>(i % 2);
    const float g = c, h = 1.0f, n_dot_h = 1.0f, v_dot_h = c;
    samples::HalfVectorTerms hv{c, &n_dot_h, &v_dot_h};
    set.AddTerms(0, 0, 0, glm::vec3(0.5f), 1, &light, &g, &h, nullptr, half_vector ? hv : samples::HalfVectorTerms{});
  }
  return set;
}

// V's denominator at the mirror configuration theta degrees from the normal.
double MirrorDenominator(double degrees) {
  brdf::Geometry g;
  g.n_dot_l = g.n_dot_v = g.v_dot_h = std::cos(degrees * kPi / 180.0);
  g.n_dot_h = 1.0;
  return brdf::Ggx::VisibilityDenominator(kRoughness, g);
}

const samples::LightMask kBoth = samples::LightMask::FirstN(2);

TEST(GgxGrazingSupportTest, IsTheMostGrazingPercentOfTheObservedLobe) {
  // Angles uniform in [0, 80] degrees: the 1 % quantile of V's denominator is
  // that of the configuration 1 % below the largest angle (79.2 degrees).
  const samples::SampleSet set = MirrorSamples(80.0, 4000);
  const GrazingSupport support = GgxGrazingSupport(set, kBoth, Lobe());
  EXPECT_EQ(support.in_lobe, 4000u);
  EXPECT_GT(support.s, MirrorDenominator(80.0));
  EXPECT_NEAR(support.s, MirrorDenominator(79.2), 0.1 * MirrorDenominator(79.2));
  // Fewer than 1 % of the in-lobe terms lie below it.
  size_t below = 0;
  for (size_t i = 0; i < set.size(); ++i) {
    below += brdf::Ggx::VisibilityDenominator(kRoughness, TermGeometry(set, i, set.TermsBegin(i))) < support.s;
  }
  EXPECT_LE(below, 40u);
}

TEST(GgxGrazingSupportTest, ACaptureThatSawLessOfGrazingHoldsTheLobeSooner) {
  const double seen_to_60 = GgxGrazingSupport(MirrorSamples(60.0, 2000), kBoth, Lobe()).s;
  const double seen_to_85 = GgxGrazingSupport(MirrorSamples(85.0, 2000), kBoth, Lobe()).s;
  EXPECT_GT(seen_to_60, seen_to_85);
  EXPECT_NEAR(seen_to_60, MirrorDenominator(59.4), 0.05 * MirrorDenominator(59.4));
}

TEST(GgxGrazingSupportTest, OnlyTermsInsideTheLobeCount) {
  // Terms far from the mirror direction (n.h 0.8, outside a roughness-0.2
  // lobe) say nothing of how far towards grazing the lobe was seen.
  samples::SampleSet set = MirrorSamples(40.0, 500);
  for (int i = 0; i < 500; ++i) {
    const uint16_t light = 0;
    const float g = 0.1f, h = 0.0f, n_dot_h = 0.8f, v_dot_h = 0.2f;
    set.AddTerms(0, 0, 0, glm::vec3(0.5f), 1, &light, &g, &h, nullptr, samples::HalfVectorTerms{0.1f, &n_dot_h, &v_dot_h});
  }
  const GrazingSupport support = GgxGrazingSupport(set, kBoth, Lobe());
  EXPECT_EQ(support.in_lobe, 500u);
  EXPECT_NEAR(support.s, MirrorDenominator(39.6), 0.05 * MirrorDenominator(39.6));
  // A broad lobe (roughness 0.9) takes them in, and they are more grazing.
  EXPECT_EQ(GgxGrazingSupport(set, kBoth, Lobe(0.9)).in_lobe, 1000u);
}

TEST(GgxGrazingSupportTest, NoSupportWithoutEvidence) {
  // No half-vector geometry, too few in-lobe terms, or no selected light: 0.
  EXPECT_EQ(GgxGrazingSupport(MirrorSamples(80.0, 100, /*half_vector=*/false), kBoth, Lobe()).s, 0.0);
  GrazingSupportOptions options;
  options.min_terms = 200;
  const GrazingSupport few = GgxGrazingSupport(MirrorSamples(80.0, 100), kBoth, Lobe(), options);
  EXPECT_EQ(few.in_lobe, 100u);
  EXPECT_EQ(few.s, 0.0);
  EXPECT_EQ(GgxGrazingSupport(MirrorSamples(80.0, 100), samples::LightMask(), Lobe()).in_lobe, 0u);
  // One light of two: half the terms.
  EXPECT_EQ(GgxGrazingSupport(MirrorSamples(80.0, 100), samples::LightMask::FirstN(1), Lobe()).in_lobe, 50u);
}

TEST(GgxGrazingSupportTest, DoesNotDependOnIntensityUnits) {
  testing::LobeTruth truth{BrdfModel::kGgx, Lobe()};
  const samples::SampleSet a = testing::RenderLobeSamples(truth, 2000, 0.0, 3, 1.0, 0, 0.0);
  const samples::SampleSet b = testing::RenderLobeSamples(truth, 2000, 0.0, 3, 1000.0, 0, 0.0);
  const GrazingSupport sa = GgxGrazingSupport(a, samples::LightMask::FirstN(6), Lobe());
  const GrazingSupport sb = GgxGrazingSupport(b, samples::LightMask::FirstN(6), Lobe());
  EXPECT_GT(sa.s, 0.0);
  EXPECT_EQ(sa.s, sb.s);
  EXPECT_EQ(sa.in_lobe, sb.in_lobe);
}

}  // namespace
}  // namespace mvbrdf::fit
