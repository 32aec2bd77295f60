#include "core/pipeline/memory_estimate.h"

#include <gtest/gtest.h>

#include "core/pipeline/texel_illumination.h"
#include "core/pipeline/texel_reservoir.h"

namespace mvbrdf::pipeline {
namespace {

// The light-dependent estimate against what the texel pass really allocates
// per texel (its TexelIllumination and TexelReservoir, MemoryBytes) plus the
// shadow atlas's extra channels, for OLAT (one light on per frame) and dense
// (every light on) captures at 16..256 lights: never below it, and not far
// above (the check must neither pass what cannot fit nor refuse what can).
TEST(MemoryEstimateTest, LightTermsMatchWhatTheTexelPassAllocates) {
  constexpr size_t kTexels = 64 * 64;
  for (size_t lights : {1u, 16u, 40u, 96u, 256u}) {
    for (bool dense : {false, true}) {
      LightLoad load;
      load.num_lights = lights;
      load.max_lights_on = dense ? lights : 1;
      load.num_configurations = 2;
      load.reservoir_slots = 4;
      const TexelIllumination illumination(kTexels, std::vector<glm::vec3>(lights, glm::vec3(1.0f)),
                                           std::vector<samples::LightMask>(2, samples::AllLights(lights)));
      const TexelReservoir reservoir(kTexels, static_cast<int>(lights), 2, 2, false, load.max_lights_on);
      const size_t shadow_channels = (lights + 15) / 16;
      const double allocated = static_cast<double>(illumination.MemoryBytes() + reservoir.MemoryBytes()) / kTexels +
                               2.0 * 2.0 * static_cast<double>(shadow_channels - 1);
      const double estimated = static_cast<double>(LightBytesPerTexel(load));
      EXPECT_GE(estimated, allocated * 0.95) << lights << " lights, dense " << dense;
      EXPECT_LE(estimated, allocated * 1.25) << lights << " lights, dense " << dense;
    }
  }
}

TEST(MemoryEstimateTest, GrowsWithTheLightsAndOnlyThroughThem) {
  // One light and no texel pass: the measured baseline alone.
  LightLoad one;
  one.num_lights = 1;
  EXPECT_EQ(LightBytesPerTexel(one), 0u);
  EXPECT_EQ(EstimatedAtlasBytes(1024, one), EstimatedAtlasBytes(1024));
  EXPECT_EQ(EstimatedAtlasBytes(1024), uint64_t{1024} * 1024 * kBytesPerAtlasTexel);
  // Resampling 256 lights: 15 extra shadow channels, twice.
  LightLoad resample;
  resample.num_lights = 256;
  EXPECT_EQ(LightBytesPerTexel(resample), 2u * 15u * 2u);
  // A run over 256 dome lights all on at once: the reservoir's rows dominate,
  // the per-configuration sums stay 24 B per configuration (per-light sums
  // would be 1 KiB per texel).
  LightLoad studio = resample;
  studio.max_lights_on = 256;
  studio.num_configurations = 1;
  studio.reservoir_slots = 4;
  EXPECT_EQ(LightBytesPerTexel(studio), 60u + 24u + 4u + 4u * (12u + 12u + 256u * 10u));
  EXPECT_GT(EstimatedAtlasBytes(1024, studio), 10 * EstimatedAtlasBytes(1024));
  // With inverse-square fall-off each kept term also holds a_k.
  LightLoad falloff = studio;
  falloff.falloff = true;
  EXPECT_EQ(LightBytesPerTexel(falloff), LightBytesPerTexel(studio) + 4u * 256u * 4u);
}

}  // namespace
}  // namespace mvbrdf::pipeline
