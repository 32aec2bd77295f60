// SpecularSums (ln h once per light for the three channels) gives the three
// channels' SpecularSum bit for bit, so that ShadeTexel's G and S, and the
// texel pass's residuals and camera errors, are the same whichever it uses.
#include "core/pipeline/texel_shading.h"

#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "core/base/draw_order.h"

namespace mvbrdf::pipeline {
namespace {

// The reference: the sum the texel passes took per channel before
// SpecularSums, I_k a_k h_k^ke over the lights in `mask`, channel c.
float SpecularSum(const samples::LightTerms& terms, const std::vector<glm::vec3>& intensity,
                  const samples::LightMask& mask, int c, double ke) {
  double s = 0.0;
  for (size_t j = 0; j < terms.count; ++j) {
    const size_t k = terms.light[j];
    if (!mask.Test(k) || !(terms.h[j] > 0.0f)) continue;
    s += intensity[k][c] * terms.falloff[j] * std::exp(ke * std::log(static_cast<double>(terms.h[j])));
  }
  return static_cast<float>(s);
}

TEST(TexelShadingTest, SpecularSumsIsSpecularSumPerChannelBitForBit) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  constexpr size_t kLights = 12;
  std::vector<glm::vec3> intensity(kLights);
  for (glm::vec3& i : intensity) i = base::DrawVec3<glm::vec3>([&] { return unit(rng); }) * 5.0f;
  for (int trial = 0; trial < 2000; ++trial) {
    std::vector<uint16_t> light;
    std::vector<float> g, h, falloff;
    for (size_t k = 0; k < kLights; ++k) {
      if (unit(rng) < 0.3f) continue;
      light.push_back(static_cast<uint16_t>(k));
      g.push_back(unit(rng));
      // Some terms without a highlight (h <= 0: left out) and some at h = 1.
      const float u = unit(rng);
      h.push_back(u < 0.1f ? -u : u > 0.95f ? 1.0f : u);
      falloff.push_back(0.5f + unit(rng));
    }
    samples::LightTerms terms;
    terms.count = light.size();
    terms.light = light.data();
    terms.g = g.data();
    terms.h = h.data();
    terms.falloff = falloff.data();
    const samples::LightMask mask = samples::LightMask::FromBits(trial % 7 == 0 ? 0x5a5u : 0xfffu);
    fit::PhongRgb phong;
    for (int c = 0; c < 3; ++c) {
      phong[c].ks = unit(rng);
      phong[c].ke = 1.0 + 300.0 * unit(rng) * unit(rng);
    }
    const glm::vec3 sums = SpecularSums(terms, intensity, mask, phong);
    for (int c = 0; c < 3; ++c) {
      const float one = SpecularSum(terms, intensity, mask, c, phong[c].ke);
      EXPECT_EQ(std::memcmp(&one, &sums[c], sizeof(float)), 0) << "trial " << trial << " channel " << c;
    }
    // ShadeTexel's S is ks (as float) times them; G the illumination.
    ClusterShading cluster;
    cluster.phong = phong;
    glm::vec3 illumination, specular, phong_sums;
    ShadeTexel(cluster, terms, intensity, mask, &illumination, &specular, &phong_sums);
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(specular[c], static_cast<float>(phong[c].ks) * sums[c]);
      EXPECT_EQ(phong_sums[c], sums[c]);
    }
    EXPECT_EQ(illumination, IlluminationOf(terms, intensity, mask));
  }
}

}  // namespace
}  // namespace mvbrdf::pipeline
