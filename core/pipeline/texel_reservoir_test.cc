#include "core/pipeline/texel_reservoir.h"

#include <algorithm>
#include <set>

#include <gtest/gtest.h>

namespace mvbrdf::pipeline {
namespace {

samples::SampleSet TwoLights() {
  samples::SampleSet set;
  set.light_names = {"A", "B"};
  set.light_intensity = {glm::vec3(1.0f), glm::vec3(1.0f)};
  return set;
}

TEST(TexelReservoirTest, KeepsTheBrightestHighlightsAndAUniformShare) {
  TexelReservoir reservoir(4, 2, 2, 2);
  // Texel 1 sees 100 observations; observation i has h = (i / 100, 0).
  for (int i = 0; i < 100; ++i) {
    const float g[2] = {0.5f, 0.5f};
    const float h[2] = {static_cast<float>(i) / 100.0f, 0.0f};
    reservoir.Offer(1, i, 0, glm::vec3(static_cast<float>(i)), g, h);
  }
  samples::SampleSet set = TwoLights();
  reservoir.Collect({0, 1, 2}, 1000, &set);
  ASSERT_EQ(set.size(), 4u);  // texels 0 and 2 saw nothing
  std::multiset<int> frames(set.frame.begin(), set.frame.end());
  // The two highest highlight cosines are kept (the uniform slots may hold
  // them a second time).
  EXPECT_GE(frames.count(99), 1u);
  EXPECT_GE(frames.count(98), 1u);
  for (size_t i = 0; i < set.size(); ++i) {
    EXPECT_EQ(set.element[i], 1u);
    EXPECT_FLOAT_EQ(set.reflectance[i].x, static_cast<float>(set.frame[i]));  // rows stay with their frame
    EXPECT_FLOAT_EQ(set.h[i * 2], set.frame[i] / 100.0f);
  }
}

TEST(TexelReservoirTest, UniformSlotsSampleEveryObservation) {
  // Over many texels the uniform slots keep each observation number about
  // equally often (reservoir sampling), deterministically.
  constexpr int kTexels = 4000, kObservations = 20;
  TexelReservoir a(kTexels, 1, 2, 0), b(kTexels, 1, 2, 0);
  for (uint32_t t = 0; t < kTexels; ++t) {
    for (int i = 0; i < kObservations; ++i) {
      const float g = 1.0f, h = 0.0f;
      a.Offer(t, i, 0, glm::vec3(0.0f), &g, &h);
      b.Offer(t, i, 0, glm::vec3(0.0f), &g, &h);
    }
  }
  samples::SampleSet sa, sb;
  sa.light_names = sb.light_names = {"A"};
  sa.light_intensity = sb.light_intensity = {glm::vec3(1.0f)};
  std::vector<uint32_t> all(kTexels);
  for (uint32_t t = 0; t < kTexels; ++t) all[t] = t;
  a.Collect(all, 1u << 30, &sa);
  b.Collect(all, 1u << 30, &sb);
  ASSERT_EQ(sa.size(), 2u * kTexels);
  EXPECT_EQ(sa.frame, sb.frame);
  std::vector<int> histogram(kObservations, 0);
  for (uint16_t f : sa.frame) ++histogram[f];
  const double expected = 2.0 * kTexels / kObservations;  // 400
  for (int i = 0; i < kObservations; ++i) EXPECT_NEAR(histogram[i], expected, 0.25 * expected) << "observation " << i;
}

TEST(TexelReservoirTest, CapAndFalloff) {
  TexelReservoir reservoir(3, 1, 1, 1, /*falloff=*/true);
  for (uint32_t t = 0; t < 3; ++t) {
    const float g = 1.0f, h = 0.9f, a = 0.25f;
    reservoir.Offer(t, 0, 0, glm::vec3(1.0f), &g, &h, &a);
  }
  samples::SampleSet set;
  set.light_names = {"A"};
  set.light_intensity = {glm::vec3(1.0f)};
  reservoir.Collect({0, 1, 2}, 3, &set);
  EXPECT_LE(set.size(), 4u);  // whole texels: stops once the cap is reached
  ASSERT_FALSE(set.falloff.empty());
  EXPECT_FLOAT_EQ(set.Falloff(0, 0), 0.25f);
}

}  // namespace
}  // namespace mvbrdf::pipeline
