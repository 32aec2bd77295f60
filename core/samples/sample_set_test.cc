#include "core/samples/sample_set.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "absl/status/status.h"
#include "core/samples/half_float.h"

namespace mvbrdf::samples {
namespace {

// Half precision: 11 significant bits, so a relative error of at most 2^-11
// after round-to-nearest for normal values; values below 2^-14 are
// subnormal with an absolute error of at most 2^-25.
constexpr float kHalfRelative = 1.0f / 2048.0f;
constexpr float kHalfAbsolute = 1.0f / 33554432.0f;

float Bits(uint32_t b) {
  float f;
  std::memcpy(&f, &b, 4);
  return f;
}

SampleSet MakeSet(int num_lights, int num_samples, uint32_t seed) {
  SampleSet set;
  for (int k = 0; k < num_lights; ++k) {
    set.light_names.push_back("light " + std::to_string(k));
    set.light_intensity.emplace_back(1.0f + 0.1f * k, 0.5f, 2.0f - 0.05f * k);
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::vector<float> g(num_lights), h(num_lights);
  for (int i = 0; i < num_samples; ++i) {
    for (int k = 0; k < num_lights; ++k) {
      g[k] = unit(rng);
      h[k] = (k % 3 == 0) ? 0.0f : unit(rng);
    }
    set.Add(static_cast<uint32_t>(rng()), i % 70000 % 65536, i % 7, glm::vec3(unit(rng), unit(rng), unit(rng)),
            g.data(), h.data());
  }
  return set;
}

void ExpectSameLayout(const SampleSet& a, const SampleSet& b) {
  EXPECT_EQ(a.light_names, b.light_names);
  ASSERT_EQ(a.light_intensity.size(), b.light_intensity.size());
  for (size_t k = 0; k < a.light_intensity.size(); ++k) EXPECT_EQ(a.light_intensity[k], b.light_intensity[k]);
  EXPECT_EQ(a.element, b.element);
  EXPECT_EQ(a.frame, b.frame);
  EXPECT_EQ(a.camera, b.camera);
  ASSERT_EQ(a.reflectance.size(), b.reflectance.size());
  ASSERT_EQ(a.g.size(), b.g.size());
  ASSERT_EQ(a.h.size(), b.h.size());
}

void ExpectNearHalf(float expected, float actual) {
  EXPECT_NEAR(actual, expected, std::max(kHalfAbsolute, std::abs(expected) * kHalfRelative)) << expected;
}

TEST(HalfFloat, EveryHalfSurvivesTheRoundTrip) {
  for (uint32_t h = 0; h < 65536; ++h) {
    const float f = HalfToFloat(static_cast<uint16_t>(h));
    if (std::isnan(f)) {
      EXPECT_EQ((h >> 10) & 0x1f, 0x1fu);
      EXPECT_TRUE(std::isnan(HalfToFloat(FloatToHalf(f))));
      continue;
    }
    EXPECT_EQ(FloatToHalf(f), h) << "half 0x" << std::hex << h;
  }
}

TEST(HalfFloat, KnownValues) {
  EXPECT_EQ(FloatToHalf(0.0f), 0x0000);
  EXPECT_EQ(FloatToHalf(-0.0f), 0x8000);
  EXPECT_EQ(FloatToHalf(1.0f), 0x3c00);
  EXPECT_EQ(FloatToHalf(-2.0f), 0xc000);
  EXPECT_EQ(FloatToHalf(65504.0f), 0x7bff);
  EXPECT_EQ(FloatToHalf(65519.0f), 0x7bff);  // below the tie: stays finite
  EXPECT_EQ(FloatToHalf(65520.0f), 0x7c00);  // the tie to even is infinity
  EXPECT_EQ(FloatToHalf(1e10f), 0x7c00);
  EXPECT_EQ(FloatToHalf(-std::numeric_limits<float>::infinity()), 0xfc00);
  EXPECT_EQ(FloatToHalf(std::ldexp(1.0f, -24)), 0x0001);  // smallest subnormal
  EXPECT_EQ(FloatToHalf(std::ldexp(1.0f, -25)), 0x0000);  // tie: to even zero
  EXPECT_EQ(FloatToHalf(std::ldexp(1.5f, -25)), 0x0001);
  EXPECT_EQ(FloatToHalf(std::ldexp(3.0f, -25)), 0x0002);  // 1.5 ulp: tie to even 2
  EXPECT_EQ(FloatToHalf(std::ldexp(1.0f, -14)), 0x0400);  // smallest normal
  EXPECT_TRUE(std::isnan(HalfToFloat(FloatToHalf(std::numeric_limits<float>::quiet_NaN()))));
}

TEST(HalfFloat, TiesRoundToEven) {
  // 1 + 2^-11 lies halfway between 1 (even mantissa) and 1 + 2^-10: to 1.
  EXPECT_EQ(FloatToHalf(1.0f + std::ldexp(1.0f, -11)), 0x3c00);
  // 1 + 3 * 2^-11 lies halfway between 1 + 2^-10 (odd) and 1 + 2^-9: up.
  EXPECT_EQ(FloatToHalf(1.0f + 3.0f * std::ldexp(1.0f, -11)), 0x3c02);
  // Just above a tie rounds up.
  EXPECT_EQ(FloatToHalf(std::nextafter(1.0f + std::ldexp(1.0f, -11), 2.0f)), 0x3c01);
  // Every midpoint between two adjacent finite halves goes to the even one.
  for (uint32_t h = 0; h < 0x7bff; ++h) {
    const double lo = HalfToFloat(static_cast<uint16_t>(h));
    const double hi = HalfToFloat(static_cast<uint16_t>(h + 1));
    const float mid = static_cast<float>((lo + hi) / 2);  // exact in float
    ASSERT_EQ(static_cast<double>(mid), (lo + hi) / 2);
    EXPECT_EQ(FloatToHalf(mid), (h & 1u) ? h + 1 : h) << "between 0x" << std::hex << h << " and 0x" << h + 1;
    EXPECT_EQ(FloatToHalf(-mid), ((h & 1u) ? h + 1 : h) | 0x8000u);
  }
}

#if defined(__FLT16_MAX__)
// The compiler's own conversion (IEEE round-to-nearest-even) as a reference
// over a stride of all float bit patterns.
TEST(HalfFloat, MatchesTheCompilersFloat16) {
  for (uint64_t b = 0; b <= 0xffffffffull; b += 4093) {
    const float f = Bits(static_cast<uint32_t>(b));
    if (std::isnan(f)) continue;
    const _Float16 reference = static_cast<_Float16>(f);
    uint16_t expected;
    std::memcpy(&expected, &reference, 2);
    ASSERT_EQ(FloatToHalf(f), expected) << "float bits 0x" << std::hex << b;
    ASSERT_EQ(HalfToFloat(expected), static_cast<float>(reference));
  }
}
#endif

TEST(SampleSet, AddStoresRows) {
  SampleSet set;
  set.light_names = {"NE", "NW"};
  set.light_intensity = {glm::vec3(1.0f), glm::vec3(2.0f, 3.0f, 4.0f)};
  const float g[] = {0.5f, 0.25f};
  const float h[] = {0.0f, 0.75f};
  set.Add(42, 3, 1, glm::vec3(0.1f, 0.2f, 0.3f), g, h);
  set.Add(43, 4, 2, glm::vec3(0.4f), h, g);
  ASSERT_EQ(set.size(), 2u);
  EXPECT_EQ(set.element[1], 43u);
  EXPECT_EQ(set.frame[0], 3);
  EXPECT_EQ(set.camera[1], 2);
  EXPECT_EQ(set.g, (std::vector<float>{0.5f, 0.25f, 0.0f, 0.75f}));
  EXPECT_EQ(set.h, (std::vector<float>{0.0f, 0.75f, 0.5f, 0.25f}));
  EXPECT_GE(set.MemoryBytes(), sizeof(SampleSet) + 2 * (4 + 2 + 1 + 12 + 16));
}

TEST(SampleSet, FalloffRowsBackfillOnes) {
  SampleSet set;
  set.light_names = {"A", "B"};
  set.light_intensity = {glm::vec3(1.0f), glm::vec3(1.0f)};
  const float g[] = {0.5f, 0.25f};
  const float h[] = {0.0f, 0.75f};
  const float a[] = {0.25f, 0.125f};
  set.Add(0, 0, 0, glm::vec3(0.0f), g, h);
  EXPECT_TRUE(set.falloff.empty());
  EXPECT_EQ(set.Falloff(0, 1), 1.0f);
  set.Add(1, 0, 0, glm::vec3(0.0f), g, h, a);
  set.Add(2, 0, 0, glm::vec3(0.0f), g, h);
  EXPECT_EQ(set.falloff, (std::vector<float>{1.0f, 1.0f, 0.25f, 0.125f, 1.0f, 1.0f}));
  EXPECT_EQ(set.Falloff(1, 1), 0.125f);

  SampleSet first;
  first.light_names = set.light_names;
  first.light_intensity = set.light_intensity;
  first.Add(0, 0, 0, glm::vec3(0.0f), g, h, a);  // fall-off on the very first sample
  EXPECT_EQ(first.falloff, (std::vector<float>{0.25f, 0.125f}));

  for (bool compact : {false, true}) {
    auto decoded = DecodeSampleSet(EncodeSampleSet(set, compact));
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_EQ(decoded->falloff, set.falloff);  // all exact in half too
    EXPECT_EQ(decoded->g, set.g);
  }
}

TEST(SampleSet, MaskOfAndIllumination) {
  SampleSet set;
  set.light_names = {"C", "NE", "NW"};
  set.light_intensity = {glm::vec3(1.0f), glm::vec3(2.0f, 3.0f, 4.0f), glm::vec3(0.5f)};
  const float g[] = {0.5f, 0.25f, 1.0f};
  const float h[] = {0.0f, 0.0f, 0.0f};
  set.Add(0, 0, 0, glm::vec3(0.0f), g, h);

  auto mask = set.MaskOf({"NW", "NE"});
  ASSERT_TRUE(mask.ok()) << mask.status();
  EXPECT_EQ(*mask, 0b110u);
  EXPECT_EQ(*set.MaskOf({}), 0u);
  const glm::vec3 e = set.Illumination(0, *mask);
  EXPECT_FLOAT_EQ(e.r, 2.0f * 0.25f + 0.5f * 1.0f);
  EXPECT_FLOAT_EQ(e.g, 3.0f * 0.25f + 0.5f * 1.0f);
  EXPECT_FLOAT_EQ(e.b, 4.0f * 0.25f + 0.5f * 1.0f);
  EXPECT_EQ(set.Illumination(0, 0), glm::vec3(0.0f));

  auto bad = set.MaskOf({"NE", "SW"});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("\"SW\""), absl::string_view::npos) << bad.status();
}

TEST(SampleSetEncoding, FloatRoundTripIsExact) {
  const SampleSet set = MakeSet(4, 300, 7);
  const std::string bytes = EncodeSampleSet(set, /*compact=*/false);
  auto decoded = DecodeSampleSet(bytes);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  ExpectSameLayout(set, *decoded);
  for (size_t i = 0; i < set.size(); ++i) EXPECT_EQ(set.reflectance[i], decoded->reflectance[i]);
  EXPECT_EQ(set.g, decoded->g);
  EXPECT_EQ(set.h, decoded->h);
}

TEST(SampleSetEncoding, CompactRoundTripWithinHalfPrecision) {
  const SampleSet set = MakeSet(9, 300, 8);
  const std::string bytes = EncodeSampleSet(set, /*compact=*/true);
  auto decoded = DecodeSampleSet(bytes);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  ExpectSameLayout(set, *decoded);
  for (size_t i = 0; i < set.size(); ++i) {
    for (int c = 0; c < 3; ++c) ExpectNearHalf(set.reflectance[i][c], decoded->reflectance[i][c]);
  }
  for (size_t j = 0; j < set.g.size(); ++j) {
    ExpectNearHalf(set.g[j], decoded->g[j]);
    ExpectNearHalf(set.h[j], decoded->h[j]);
    EXPECT_EQ(set.h[j] == 0.0f, decoded->h[j] == 0.0f);  // h = 0 stays exactly 0
  }
  // Re-encoding the decoded set reproduces the bytes (halves are exact in float).
  EXPECT_EQ(EncodeSampleSet(*decoded, true), bytes);
}

TEST(SampleSetEncoding, SizesPerSample) {
  // Header 24 bytes; per light 4 + name + 12; per sample 7 + real * (3 + 2 L).
  for (int lights : {4, 9}) {
    const SampleSet set = MakeSet(lights, 1000, 9);
    size_t names = 0;
    for (const std::string& n : set.light_names) names += 16 + n.size();
    const size_t compact = EncodeSampleSet(set, true).size();
    const size_t full = EncodeSampleSet(set, false).size();
    EXPECT_EQ(compact, 24 + names + 1000 * (7 + 2 * (3 + 2 * lights)));
    EXPECT_EQ(full, 24 + names + 1000 * (7 + 4 * (3 + 2 * lights)));
    std::printf("%d lights: %zu bytes/sample compact, %zu bytes/sample float (in memory %zu)\n", lights,
                size_t(7 + 2 * (3 + 2 * lights)), size_t(7 + 4 * (3 + 2 * lights)), size_t(7 + 12 + 8 * lights));
  }
}

TEST(SampleSetEncoding, EmptySets) {
  for (int lights : {0, 3}) {
    for (bool compact : {false, true}) {
      const SampleSet set = MakeSet(lights, 0, 1);
      auto decoded = DecodeSampleSet(EncodeSampleSet(set, compact));
      ASSERT_TRUE(decoded.ok()) << decoded.status();
      EXPECT_EQ(decoded->size(), 0u);
      EXPECT_EQ(decoded->light_names, set.light_names);
    }
  }
}

TEST(SampleSetEncoding, SixteenLights) {
  SampleSet set = MakeSet(kMaxLights, 50, 3);
  set.light_names[15] = "";  // an empty name is legal
  auto decoded = DecodeSampleSet(EncodeSampleSet(set, false));
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  ExpectSameLayout(set, *decoded);
  EXPECT_EQ(set.g, decoded->g);
  auto mask = decoded->MaskOf({"light 14", ""});
  ASSERT_TRUE(mask.ok());
  EXPECT_EQ(*mask, 0xc000u);
}

void ExpectDataLoss(absl::string_view bytes, absl::string_view what) {
  auto decoded = DecodeSampleSet(bytes);
  ASSERT_FALSE(decoded.ok());
  EXPECT_EQ(decoded.status().code(), absl::StatusCode::kDataLoss) << decoded.status();
  EXPECT_NE(decoded.status().message().find(what), absl::string_view::npos)
      << "expected \"" << what << "\" in: " << decoded.status();
}

TEST(SampleSetEncoding, EveryPrefixFailsCleanly) {
  for (bool compact : {false, true}) {
    const std::string bytes = EncodeSampleSet(MakeSet(2, 3, 5), compact);
    for (size_t n = 0; n < bytes.size(); ++n) {
      auto decoded = DecodeSampleSet(absl::string_view(bytes.data(), n));
      ASSERT_FALSE(decoded.ok()) << "prefix " << n;
      EXPECT_EQ(decoded.status().code(), absl::StatusCode::kDataLoss) << decoded.status();
    }
    EXPECT_TRUE(DecodeSampleSet(bytes).ok());
    ExpectDataLoss(bytes + "x", "counts inconsistent");  // a trailing byte
  }
}

TEST(SampleSetEncoding, ForeignAndCorruptBuffers) {
  const std::string good = EncodeSampleSet(MakeSet(2, 3, 5), true);
  ExpectDataLoss("", "truncated magic");
  ExpectDataLoss("PNG\x89 not a sample set at all", "bad magic");
  ExpectDataLoss(std::string(64, '\0'), "bad magic");

  std::string version = good;
  version[4] = 2;
  ExpectDataLoss(version, "unknown version 2");

  std::string flags = good;
  flags[8] |= 0x04;
  ExpectDataLoss(flags, "unknown flags");

  std::string lights = good;
  lights[12] = 17;
  ExpectDataLoss(lights, "light count 17");

  std::string name = good;
  name[24 + 3] = 0x7f;  // light 0's name length, top byte
  ExpectDataLoss(name, "name length");

  // Flipping the compact flag makes the arrays the wrong length.
  std::string mode = good;
  mode[8] = 0;
  ExpectDataLoss(mode, "sample count");
}

// Found by tests/fuzz/sample_set_fuzz (corpus/sample_set/falloff_flag_empty.mvss):
// the falloff flag on a set with no falloff values decoded, and re-encoded
// without it, so one set had two encodings.
TEST(SampleSetEncoding, FalloffFlagWithoutValuesFails) {
  const std::string no_samples("MVSS\x01\0\0\0\x02\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0", 24);
  ExpectDataLoss(no_samples, "falloff flag set but there are no falloff values (0 samples x 0 lights)");
  // One sample, no lights: element, frame, camera and three halves.
  std::string no_lights = no_samples + std::string(13, '\0');
  no_lights[8] = 3;  // compact | falloff
  no_lights[16] = 1;
  ExpectDataLoss(no_lights, "(1 samples x 0 lights)");
  no_lights[8] = 1;  // compact only: fine
  EXPECT_TRUE(DecodeSampleSet(no_lights).ok());
  // Encoded sets with fall-off still decode.
  SampleSet set = MakeSet(2, 3, 5);
  set.falloff.assign(set.g.size(), 0.5f);
  auto decoded = DecodeSampleSet(EncodeSampleSet(set, false));
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(decoded->falloff, set.falloff);
}

TEST(SampleSetEncoding, ByteFlippedCountFails) {
  const std::string good = EncodeSampleSet(MakeSet(2, 3, 5), false);
  for (int byte = 0; byte < 8; ++byte) {
    std::string bad = good;
    bad[16 + byte] = static_cast<char>(bad[16 + byte] ^ 0xff);  // the u64 sample count
    auto decoded = DecodeSampleSet(bad);  // must not try to allocate 2^60 samples
    ASSERT_FALSE(decoded.ok()) << "byte " << byte;
    EXPECT_EQ(decoded.status().code(), absl::StatusCode::kDataLoss);
  }
  std::string fewer = good;
  fewer[16] = 2;  // 2 samples declared, 3 stored
  ExpectDataLoss(fewer, "counts inconsistent");
}

TEST(SampleSetEncoding, RandomCorruptionNeverCrashes) {
  const std::string good = EncodeSampleSet(MakeSet(3, 4, 6), true);
  std::mt19937 rng(11);
  for (int trial = 0; trial < 2000; ++trial) {
    std::string bad = good;
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int f = 0; f < flips; ++f) bad[rng() % 40] = static_cast<char>(rng());
    auto decoded = DecodeSampleSet(bad);  // decodes or fails; either way no crash
    if (!decoded.ok()) {
      EXPECT_EQ(decoded.status().code(), absl::StatusCode::kDataLoss);
    }
  }
}

}  // namespace
}  // namespace mvbrdf::samples
