#include "core/pipeline/texel_illumination.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "core/base/draw_order.h"

namespace mvbrdf::pipeline {
namespace {

using Layout = TexelIllumination::Layout;

// 256 dome lights, OLAT-like observations (one or a few lights each): both
// layouts give the exact sum sum_obs sum_{k in mask} I_k g_k (computed here
// in double beside them), the per-configuration one in a fraction of the
// memory.
TEST(TexelIlluminationTest, BothLayoutsGiveTheIlluminationOfEachConfiguration) {
  constexpr size_t kLights = 256, kTexels = 50;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::vector<glm::vec3> intensity;
  for (size_t k = 0; k < kLights; ++k) intensity.push_back(base::DrawVec3<glm::vec3>([&] { return unit(rng); }) * 3.0f + 0.1f);
  samples::LightMask odd, high;
  for (size_t k = 1; k < kLights; k += 2) odd.Set(k);
  for (size_t k = 200; k < kLights; ++k) high.Set(k);
  const std::vector<samples::LightMask> masks = {samples::AllLights(kLights), odd, high};
  TexelIllumination per_light(kTexels, intensity, masks, Layout::kPerLight);
  TexelIllumination per_config(kTexels, intensity, masks, Layout::kPerConfiguration);
  TexelIllumination chosen(kTexels, intensity, masks);
  EXPECT_EQ(chosen.layout(), Layout::kPerConfiguration);
  EXPECT_EQ(per_light.MemoryBytes(), kTexels * kLights * sizeof(float));
  EXPECT_EQ(per_config.MemoryBytes(), kTexels * masks.size() * sizeof(glm::dvec3));
  std::vector<glm::dvec3> truth(kTexels * masks.size(), glm::dvec3(0.0));
  for (int obs = 0; obs < 20000; ++obs) {
    const uint32_t texel = static_cast<uint32_t>(rng() % kTexels);
    std::vector<uint16_t> lights;
    std::vector<float> g;
    for (size_t k = rng() % 8; k < kLights; k += 1 + rng() % 100) {
      lights.push_back(static_cast<uint16_t>(k));
      g.push_back(unit(rng));
    }
    samples::LightTerms terms;
    terms.count = lights.size();
    terms.light = lights.data();
    terms.g = g.data();
    per_light.Add(texel, terms);
    per_config.Add(texel, terms);
    for (size_t m = 0; m < masks.size(); ++m) {
      for (size_t j = 0; j < lights.size(); ++j) {
        if (masks[m].Test(lights[j]))
          truth[texel * masks.size() + m] += glm::dvec3(intensity[lights[j]]) * double(g[j]);
      }
    }
  }
  for (uint32_t t = 0; t < kTexels; ++t) {
    for (size_t m = 0; m < masks.size(); ++m) {
      const glm::dvec3 want = truth[t * masks.size() + m];
      ASSERT_GT(want.x, 0.0);
      for (const TexelIllumination* ti : {&per_light, &per_config}) {
        const absl::StatusOr<glm::dvec3> got = ti->Of(t, masks[m]);
        ASSERT_TRUE(got.ok()) << got.status();
        for (int c = 0; c < 3; ++c) EXPECT_NEAR((*got)[c], want[c], 1e-5 * want[c]) << "texel " << t << " mask " << m;
      }
    }
  }
  // A configuration not gathered: the per-light layout can still answer,
  // the per-configuration one cannot (and says so, never a wrong number).
  samples::LightMask other;
  other.Set(3);
  EXPECT_TRUE(per_light.Of(0, other).ok());
  EXPECT_EQ(per_config.Of(0, other).status().code(), absl::StatusCode::kInternal);
}

// Observations from a frame with its own lights (samples::LightSelection)
// count under every configuration, in both layouts; the others only under the
// configurations holding their lights.
TEST(TexelIlluminationTest, OwnLitObservationsCountUnderEveryConfiguration) {
  const std::vector<glm::vec3> intensity = {glm::vec3(1.0f), glm::vec3(2.0f), glm::vec3(4.0f)};
  const samples::LightMask first = samples::LightMask::FromBits(0b001), all = samples::AllLights(3);
  const uint16_t light0 = 0, light2 = 2;
  const float g0 = 0.5f, g2 = 0.25f;
  samples::LightTerms by0{1, &light0, &g0, nullptr, nullptr, false};
  samples::LightTerms by2{1, &light2, &g2, nullptr, nullptr, false};
  for (Layout layout : {Layout::kPerLight, Layout::kPerConfiguration}) {
    TexelIllumination ti(2, intensity, {all, first}, layout);
    ti.Add(1, by0);                 // a frame without an entry, lit by light 0
    ti.Add(1, by2, /*own=*/true);   // a frame whose own light is 2, outside `first`
    ti.Add(1, by2, /*own=*/false);  // light 2 in a frame without an entry
    EXPECT_DOUBLE_EQ(ti.Of(1, first)->x, 0.5 + 1.0);
    EXPECT_DOUBLE_EQ(ti.Of(1, all)->x, 0.5 + 1.0 + 1.0);
    EXPECT_DOUBLE_EQ(ti.Of(0, first)->x, 0.0);
  }
}

TEST(TexelIlluminationTest, TheSmallerLayoutIsChosen) {
  // A few lights and many configurations: per light; many lights: per configuration.
  EXPECT_EQ(TexelIllumination::ChooseLayout(3, 4), Layout::kPerLight);
  EXPECT_EQ(TexelIllumination::ChooseLayout(6, 1), Layout::kPerLight);  // 24 B either way
  EXPECT_EQ(TexelIllumination::ChooseLayout(40, 2), Layout::kPerConfiguration);
  EXPECT_EQ(TexelIllumination::ChooseLayout(256, 300), Layout::kPerLight);
  EXPECT_EQ(TexelIllumination::BytesPerTexel(Layout::kPerLight, 256, 1), 1024u);
  EXPECT_EQ(TexelIllumination::BytesPerTexel(Layout::kPerConfiguration, 256, 1), 24u);
}

}  // namespace
}  // namespace mvbrdf::pipeline
