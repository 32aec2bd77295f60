#include "core/pipeline/texel_reservoir.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>

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
  EXPECT_FLOAT_EQ(set.TermFalloff(0), 0.25f);
}

// Issue #13: 256 candidate lights, one on per observation (OLAT). The rows
// hold the one term, not 256, and keep its light index beyond 16.
TEST(TexelReservoirTest, OneTermOfManyLights) {
  constexpr int kLights = 256;
  TexelReservoir dense(100, kLights, 2, 2), sparse(100, kLights, 2, 2, false, /*max_terms=*/1);
  EXPECT_GT(dense.MemoryBytes(), 50 * sparse.MemoryBytes());
  for (uint32_t texel = 0; texel < 100; ++texel) {
    for (int i = 0; i < 8; ++i) {
      const uint16_t light = static_cast<uint16_t>((texel + 40 * i) % kLights);
      const float g = 0.5f, h = 0.1f * static_cast<float>(i), a = 1.0f;
      samples::LightTerms terms;
      terms.count = 1;
      terms.light = &light;
      terms.g = &g;
      terms.h = &h;
      terms.falloff = &a;
      sparse.Offer(texel, i, 0, glm::vec3(static_cast<float>(light)), terms);
    }
  }
  samples::SampleSet set;
  for (int k = 0; k < kLights; ++k) {
    set.light_names.push_back("L" + std::to_string(k));
    set.light_intensity.emplace_back(1.0f);
  }
  std::vector<uint32_t> all(100);
  for (uint32_t t = 0; t < 100; ++t) all[t] = t;
  sparse.Collect(all, 1u << 30, &set);
  ASSERT_EQ(set.size(), 400u);
  ASSERT_EQ(set.num_terms(), 400u);
  bool beyond_sixteen = false;
  for (size_t i = 0; i < set.size(); ++i) {
    EXPECT_EQ(set.light[i], static_cast<uint16_t>(set.reflectance[i].x));  // the term stays with its observation
    EXPECT_EQ(set.light[i], (set.element[i] + 40 * set.frame[i]) % kLights);
    EXPECT_FLOAT_EQ(set.h[i], 0.1f * set.frame[i]);
    beyond_sixteen |= set.light[i] >= 16;
  }
  EXPECT_TRUE(beyond_sixteen);
}

// Issue #15 item 2: a reservoir that keeps the half-vector geometry hands it
// back with each kept observation (with fall-off on, so every part of a row
// is in use).
TEST(TexelReservoirTest, KeepsTheHalfVectorGeometry) {
  TexelReservoir reservoir(3, 2, 1, 1, /*falloff=*/true, 0, /*half_vector=*/true);
  for (uint32_t texel = 0; texel < 3; ++texel) {
    for (int i = 0; i < 5; ++i) {
      const uint16_t light[2] = {0, 1};
      const float f = static_cast<float>(10 * texel + i);
      const float g[2] = {0.5f, 0.25f}, h[2] = {0.01f * f, 0.02f * f}, a[2] = {0.5f, 2.0f};
      const float nh[2] = {0.001f * f, 0.002f * f}, vh[2] = {0.003f * f, 0.004f * f};
      samples::LightTerms terms;
      terms.count = 2;
      terms.light = light;
      terms.g = g;
      terms.h = h;
      terms.falloff = a;
      terms.n_dot_v = 0.005f * f;
      terms.n_dot_h = nh;
      terms.v_dot_h = vh;
      reservoir.Offer(texel, i, 0, glm::vec3(f), terms);
    }
  }
  samples::SampleSet set = TwoLights();
  set.half_vector = true;
  reservoir.Collect({0, 1, 2}, 100, &set);
  ASSERT_EQ(set.size(), 6u);
  ASSERT_EQ(set.n_dot_v.size(), 6u);
  ASSERT_EQ(set.n_dot_h.size(), 12u);
  for (size_t i = 0; i < set.size(); ++i) {
    const float f = set.reflectance[i].x;  // the observation's number, as offered
    EXPECT_FLOAT_EQ(set.n_dot_v[i], 0.005f * f);
    const size_t j = set.TermsBegin(i);
    EXPECT_FLOAT_EQ(set.h[j + 1], 0.02f * f);
    EXPECT_FLOAT_EQ(set.falloff[j + 1], 2.0f);
    EXPECT_FLOAT_EQ(set.n_dot_h[j], 0.001f * f);
    EXPECT_FLOAT_EQ(set.n_dot_h[j + 1], 0.002f * f);
    EXPECT_FLOAT_EQ(set.v_dot_h[j], 0.003f * f);
    EXPECT_FLOAT_EQ(set.v_dot_h[j + 1], 0.004f * f);
  }
  // The same reservoir without the geometry is smaller by 1 + 2 floats per term and slot.
  TexelReservoir plain(3, 2, 1, 1, true, 0, false);
  EXPECT_EQ(reservoir.MemoryBytes() - plain.MemoryBytes(), 3u * 2u * (1 + 2 * 2) * sizeof(float));
}

}  // namespace
}  // namespace mvbrdf::pipeline
