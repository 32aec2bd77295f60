#include "core/samples/sample_set.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#if defined(__x86_64__)
#include <cpuid.h>
#include <immintrin.h>
#endif

#include "absl/status/status.h"
#include "core/base/draw_order.h"
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
      // A quarter of the lights do not reach a sample (no term).
      g[k] = unit(rng) < 0.25f ? 0.0f : unit(rng);
      h[k] = (k % 3 == 0 || g[k] == 0.0f) ? 0.0f : unit(rng);
    }
    const glm::vec3 reflectance = base::DrawVec3<glm::vec3>([&] { return unit(rng); });  // drawn before the element
    set.Add(static_cast<uint32_t>(rng()), i % 70000 % 65536, i % 7, reflectance, g.data(), h.data());
  }
  return set;
}

void ExpectDataLoss(absl::string_view bytes, absl::string_view what);

void ExpectSameLayout(const SampleSet& a, const SampleSet& b) {
  EXPECT_EQ(a.light_names, b.light_names);
  ASSERT_EQ(a.light_intensity.size(), b.light_intensity.size());
  for (size_t k = 0; k < a.light_intensity.size(); ++k) EXPECT_EQ(a.light_intensity[k], b.light_intensity[k]);
  EXPECT_EQ(a.element, b.element);
  EXPECT_EQ(a.frame, b.frame);
  EXPECT_EQ(a.camera, b.camera);
  ASSERT_EQ(a.reflectance.size(), b.reflectance.size());
  EXPECT_EQ(a.offset, b.offset);
  EXPECT_EQ(a.light, b.light);
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

// A reference conversion (IEEE round-to-nearest-even) that is not ours: the
// compiler's _Float16 where it has one (gcc 12), else the CPU's F16C
// instructions (clang 14 on x86-64, which the sanitizer build uses).
#if defined(__FLT16_MAX__)
bool ReferenceAvailable() { return true; }
uint16_t ReferenceHalf(float f) {
  const _Float16 reference = static_cast<_Float16>(f);
  uint16_t bits;
  std::memcpy(&bits, &reference, 2);
  return bits;
}
float ReferenceFloat(uint16_t h) {
  _Float16 value;
  std::memcpy(&value, &h, 2);
  return static_cast<float>(value);
}
#elif defined(__x86_64__) && defined(__GNUC__)
bool ReferenceAvailable() {
  unsigned a = 0, b = 0, c = 0, d = 0;
  return __get_cpuid(1, &a, &b, &c, &d) != 0 && (c & bit_F16C) != 0;
}
#if defined(__clang__)
#pragma clang diagnostic ignored "-Wc99-extensions"  // clang's _cvtss_sh is a compound literal
#endif
__attribute__((target("f16c"))) uint16_t ReferenceHalf(float f) {
  return static_cast<uint16_t>(_cvtss_sh(f, _MM_FROUND_TO_NEAREST_INT));
}
__attribute__((target("f16c"))) float ReferenceFloat(uint16_t h) { return _cvtsh_ss(h); }
#else
bool ReferenceAvailable() { return false; }
uint16_t ReferenceHalf(float) { return 0; }
float ReferenceFloat(uint16_t) { return 0.0f; }
#endif

// The reference conversion over a stride of all float bit patterns.
TEST(HalfFloat, MatchesAReferenceConversion) {
  if (!ReferenceAvailable()) GTEST_SKIP() << "no _Float16 and no F16C here";
  for (uint64_t b = 0; b <= 0xffffffffull; b += 4093) {
    const float f = Bits(static_cast<uint32_t>(b));
    if (std::isnan(f)) continue;
    const uint16_t expected = ReferenceHalf(f);
    ASSERT_EQ(FloatToHalf(f), expected) << "float bits 0x" << std::hex << b;
    ASSERT_EQ(HalfToFloat(expected), ReferenceFloat(expected));
  }
}

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
  // Compact: the second sample's light 0 has g = 0 and is no term.
  EXPECT_EQ(set.offset, (std::vector<uint64_t>{0, 2, 3}));
  EXPECT_EQ(set.light, (std::vector<uint16_t>{0, 1, 1}));
  EXPECT_EQ(set.g, (std::vector<float>{0.5f, 0.25f, 0.75f}));
  EXPECT_EQ(set.h, (std::vector<float>{0.0f, 0.75f, 0.25f}));
  EXPECT_EQ(set.GOf(1, 0), 0.0f);
  EXPECT_EQ(set.HOf(1, 1), 0.25f);
  EXPECT_GE(set.MemoryBytes(), sizeof(SampleSet) + 2 * (4 + 2 + 1 + 12 + 8) + 3 * 10);
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
  EXPECT_EQ(set.TermFalloff(1), 1.0f);
  set.Add(1, 0, 0, glm::vec3(0.0f), g, h, a);
  set.Add(2, 0, 0, glm::vec3(0.0f), g, h);
  EXPECT_EQ(set.falloff, (std::vector<float>{1.0f, 1.0f, 0.25f, 0.125f, 1.0f, 1.0f}));
  EXPECT_EQ(set.TermFalloff(set.TermsBegin(1) + 1), 0.125f);

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
  EXPECT_EQ(*mask, LightMask::FromBits(0b110u));
  EXPECT_EQ(*set.MaskOf({}), LightMask());
  const glm::vec3 e = set.Illumination(0, *mask);
  EXPECT_FLOAT_EQ(e.r, 2.0f * 0.25f + 0.5f * 1.0f);
  EXPECT_FLOAT_EQ(e.g, 3.0f * 0.25f + 0.5f * 1.0f);
  EXPECT_FLOAT_EQ(e.b, 4.0f * 0.25f + 0.5f * 1.0f);
  EXPECT_EQ(set.Illumination(0, LightMask()), glm::vec3(0.0f));

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
  // Header 32 bytes; per light 4 + name + 12; per sample 9 + 3 real; per
  // term 2 + 2 real.
  for (int lights : {4, 9}) {
    const SampleSet set = MakeSet(lights, 1000, 9);
    size_t names = 0;
    for (const std::string& n : set.light_names) names += 16 + n.size();
    const size_t terms = set.num_terms();
    EXPECT_LT(terms, 1000u * lights);  // some lights do not reach some samples
    const size_t compact = EncodeSampleSet(set, true).size();
    const size_t full = EncodeSampleSet(set, false).size();
    EXPECT_EQ(compact, 32 + names + 1000 * (9 + 2 * 3) + terms * (2 + 2 * 2));
    EXPECT_EQ(full, 32 + names + 1000 * (9 + 4 * 3) + terms * (2 + 2 * 4));
    std::printf("%d lights, %.2f terms/sample: %.1f bytes/sample compact, %.1f float\n", lights, terms / 1000.0,
                compact / 1000.0, full / 1000.0);
  }
}

// An OLAT capture: 256 candidate lights, one on per sample. The encoding and
// the memory scale with the one term, not with the 256 candidates.
TEST(SampleSetEncoding, OneLightOfManyPerSample) {
  constexpr int kLights = 256;
  SampleSet set;
  for (int k = 0; k < kLights; ++k) {
    set.light_names.push_back("L" + std::to_string(k));
    set.light_intensity.emplace_back(1.0f);
  }
  for (int i = 0; i < 1000; ++i) {
    const uint16_t light = static_cast<uint16_t>((i * 37) % kLights);
    const float g = 0.5f, h = 0.25f;
    set.AddTerms(static_cast<uint32_t>(i), i, 0, glm::vec3(0.5f), 1, &light, &g, &h);
  }
  EXPECT_EQ(set.num_terms(), 1000u);
  const std::string bytes = EncodeSampleSet(set, true);
  size_t names = 0;
  for (const std::string& n : set.light_names) names += 16 + n.size();
  EXPECT_EQ(bytes.size(), 32 + names + 1000 * (9 + 6 + 6));
  EXPECT_LT(set.MemoryBytes(), 1000u * 60 + 20000);  // ~41 bytes per sample, not 256 x 12
  auto decoded = DecodeSampleSet(bytes);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  ExpectSameLayout(set, *decoded);
  EXPECT_EQ(decoded->light, set.light);
  // Light 255 (bit 15 of shadow channel 15) reaches sample 7 (7 * 37 % 256 = 3)... and sample i its own.
  for (int i : {0, 7, 999}) {
    const int k = (i * 37) % kLights;
    EXPECT_EQ(decoded->GOf(i, k), 0.5f);
    const glm::vec3 e = decoded->Illumination(i, LightMask::FirstN(kLights));
    EXPECT_EQ(e, glm::vec3(0.5f));
    LightMask others = LightMask::FirstN(kLights);
    others = others.Without(*decoded->MaskOf({"L" + std::to_string(k)}));
    EXPECT_EQ(decoded->Illumination(i, others), glm::vec3(0.0f));
  }
}

// Version 1 (dense rows, at most 16 lights) is refused with a clear error:
// a cache entry of it is a miss (server/workers_api recomputes).
TEST(SampleSetEncoding, VersionOneIsRefused) {
  // A version 1 buffer: header (magic, version 1, flags compact, 1 light, 1
  // sample), the light "A" with intensity 1, then the dense arrays.
  std::string v1("MVSS\x01\0\0\0\x01\0\0\0\x01\0\0\0\x01\0\0\0\0\0\0\0", 24);
  v1 += std::string("\x01\0\0\0A", 5) + std::string(12, '\0') + std::string(4 + 2 + 1 + 2 * (3 + 2), '\0');
  ExpectDataLoss(v1, "version 1 (dense rows of at most 16 lights) is no longer read");
}

TEST(SampleSetEncoding, BadTermsFail) {
  SampleSet set = MakeSet(3, 2, 5);
  set.light = {0, 1, 2, 0, 2};
  set.offset = {0, 3, 5};
  set.g.assign(5, 0.5f);
  set.h.assign(5, 0.25f);
  const std::string good = EncodeSampleSet(set, false);
  ASSERT_TRUE(DecodeSampleSet(good).ok());
  // Arrays: element 2 x 4, frame 2 x 2, camera 2, reflectance 6 x 4, counts 2 x 2, lights 5 x 2.
  const size_t counts = good.size() - 5 * (2 + 8) - 2 * 2;
  const size_t lights = counts + 4;
  std::string descending = good;
  descending[lights + 2] = 0;  // sample 0: lights 0, 0, 2
  ExpectDataLoss(descending, "not ascending");
  std::string beyond = good;
  beyond[lights + 8] = 3;  // sample 1: lights 0, 3 of 3
  ExpectDataLoss(beyond, "not ascending below 3");
  std::string too_many = good;
  too_many[counts] = 4;
  ExpectDataLoss(too_many, "4 terms, more than the 3 lights");
  std::string sum = good;
  sum[counts] = 2;  // 2 + 2 terms, the header says 5
  ExpectDataLoss(sum, "add up to 4");
}

TEST(LightMask, BitsBeyondSixtyFour) {
  LightMask m;
  EXPECT_FALSE(m.Any());
  m.Set(3);
  m.Set(200);
  m.Set(1023);
  EXPECT_TRUE(m.Test(3) && m.Test(200) && m.Test(1023));
  EXPECT_FALSE(m.Test(4) || m.Test(199) || m.Test(64) || m.Test(5000));
  EXPECT_EQ(m.Count(), 3u);
  EXPECT_EQ(m.End(), 1024u);
  std::vector<size_t> seen;
  m.ForEach([&](size_t k) { seen.push_back(k); });
  EXPECT_EQ(seen, (std::vector<size_t>{3, 200, 1023}));
  EXPECT_EQ(m.Bits16(200 / 16), 1u << (200 % 16));
  EXPECT_EQ(m.Bits16(0), 0x8u);
  const LightMask all = LightMask::FirstN(300);
  EXPECT_EQ(all.Count(), 300u);
  EXPECT_EQ(all.End(), 300u);
  EXPECT_TRUE(all.Test(299) && !all.Test(300));
  EXPECT_EQ(LightMask::FirstN(64).Count(), 64u);
  EXPECT_EQ(LightMask::FirstN(128).End(), 128u);
  EXPECT_EQ((m & all).Count(), 2u);
  EXPECT_EQ(m.Without(all), [] {
    LightMask x;
    x.Set(1023);
    return x;
  }());
  // Equality ignores how far a mask once reached.
  LightMask low = m.Without(m);
  EXPECT_EQ(low, LightMask());
  EXPECT_EQ((m | all).Count(), 301u);
  EXPECT_EQ(LightMask::FromBits(0x5).ToString(), "0x5");
  LightMask high = LightMask::FromBits(1);
  high.Set(64);
  EXPECT_EQ(high.ToString(), "0x10000000000000001");
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

TEST(SampleSetEncoding, MostLights) {
  SampleSet set = MakeSet(kMaxLights, 50, 3);
  set.light_names[15] = "";  // an empty name is legal
  auto decoded = DecodeSampleSet(EncodeSampleSet(set, false));
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  ExpectSameLayout(set, *decoded);
  EXPECT_EQ(set.g, decoded->g);
  auto mask = decoded->MaskOf({"light 14", ""});
  ASSERT_TRUE(mask.ok());
  EXPECT_EQ(*mask, LightMask::FromBits(0xc000u));
  auto high = decoded->MaskOf({"light 1000"});
  ASSERT_TRUE(high.ok());
  EXPECT_TRUE(high->Test(1000));
  EXPECT_EQ(high->Count(), 1u);
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
  version[4] = 4;
  ExpectDataLoss(version, "unknown version 4");
  version[4] = 1;
  ExpectDataLoss(version, "version 1");

  std::string flags = good;
  flags[8] |= 0x08;
  ExpectDataLoss(flags, "unknown flags");

  std::string lights = good;
  lights[12] = 1;
  lights[13] = 4;  // 1025
  ExpectDataLoss(lights, "light count 1025");

  std::string name = good;
  name[32 + 3] = 0x7f;  // light 0's name length, top byte
  ExpectDataLoss(name, "name length");

  // Flipping the compact flag makes the arrays the wrong length.
  std::string mode = good;
  mode[8] = 0;
  ExpectDataLoss(mode, "samples x");
}

// Found by tests/fuzz/sample_set_fuzz (corpus/sample_set/falloff_flag_empty.mvss):
// the falloff flag on a set with no falloff values decoded, and re-encoded
// without it, so one set had two encodings.
TEST(SampleSetEncoding, FalloffFlagWithoutValuesFails) {
  const std::string no_samples("MVSS\x02\0\0\0\x02\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0", 32);
  ExpectDataLoss(no_samples, "falloff flag set but there are no terms");
  // One sample, no lights: element, frame, camera, three halves and its count.
  std::string no_lights = no_samples + std::string(15, '\0');
  no_lights[8] = 3;  // compact | falloff
  no_lights[16] = 1;
  ExpectDataLoss(no_lights, "falloff flag set but there are no terms");
  no_lights[8] = 1;  // compact only: fine
  EXPECT_TRUE(DecodeSampleSet(no_lights).ok());
  // Encoded sets with fall-off still decode.
  SampleSet set = MakeSet(2, 3, 5);
  set.falloff.assign(set.num_terms(), 0.5f);
  auto decoded = DecodeSampleSet(EncodeSampleSet(set, false));
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(decoded->falloff, set.falloff);
}

// A set with the half-vector geometry (issue #15 item 2): n.v per sample,
// n.h and v.h per term, made from random unit vectors n, l, v as the
// assemblers make them.
SampleSet MakeHalfVectorSet(int num_lights, int num_samples, uint32_t seed) {
  SampleSet set;
  set.half_vector = true;
  for (int k = 0; k < num_lights; ++k) {
    set.light_names.push_back("light " + std::to_string(k));
    set.light_intensity.emplace_back(1.0f);
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::vector<uint16_t> light;
  std::vector<float> g, h, nh, vh;
  for (int i = 0; i < num_samples; ++i) {
    light.clear();
    g.clear();
    h.clear();
    nh.clear();
    vh.clear();
    for (int k = 0; k < num_lights; ++k) {
      if (unit(rng) < 0.3f) continue;
      light.push_back(static_cast<uint16_t>(k));
      g.push_back(unit(rng));
      h.push_back(unit(rng));
      nh.push_back(unit(rng));
      vh.push_back(unit(rng));
    }
    set.AddTerms(static_cast<uint32_t>(i), i % 50, i % 3, glm::vec3(unit(rng)), light.size(), light.data(), g.data(),
                 h.data(), nullptr, {unit(rng), nh.data(), vh.data()});
  }
  return set;
}

TEST(SampleSetEncoding, HalfVectorGeometryRoundTrips) {
  const SampleSet set = MakeHalfVectorSet(5, 400, 3);
  ASSERT_EQ(set.n_dot_v.size(), set.size());
  ASSERT_EQ(set.n_dot_h.size(), set.num_terms());
  ASSERT_EQ(set.v_dot_h.size(), set.num_terms());
  auto full = DecodeSampleSet(EncodeSampleSet(set, false));
  ASSERT_TRUE(full.ok()) << full.status();
  EXPECT_TRUE(full->half_vector);
  ExpectSameLayout(set, *full);
  EXPECT_EQ(full->n_dot_v, set.n_dot_v);
  EXPECT_EQ(full->n_dot_h, set.n_dot_h);
  EXPECT_EQ(full->v_dot_h, set.v_dot_h);
  EXPECT_EQ(full->g, set.g);
  EXPECT_EQ(full->h, set.h);
  const std::string bytes = EncodeSampleSet(set, true);
  auto compact = DecodeSampleSet(bytes);
  ASSERT_TRUE(compact.ok()) << compact.status();
  for (size_t i = 0; i < set.size(); ++i) ExpectNearHalf(set.n_dot_v[i], compact->n_dot_v[i]);
  for (size_t j = 0; j < set.num_terms(); ++j) {
    ExpectNearHalf(set.n_dot_h[j], compact->n_dot_h[j]);
    ExpectNearHalf(set.v_dot_h[j], compact->v_dot_h[j]);
  }
  EXPECT_EQ(EncodeSampleSet(*compact, true), bytes);
  // Sizes: per sample one more real (n.v), per term two more (n.h, v.h).
  size_t names = 0;
  for (const std::string& n : set.light_names) names += 16 + n.size();
  EXPECT_EQ(bytes.size(), 32 + names + set.size() * (9 + 2 * 4) + set.num_terms() * (2 + 2 * 4));
  // Without the geometry the set is today's: no arrays, no flag.
  const SampleSet plain = MakeSet(5, 10, 3);
  EXPECT_FALSE(plain.half_vector);
  EXPECT_TRUE(plain.n_dot_v.empty() && plain.n_dot_h.empty() && plain.v_dot_h.empty());
  EXPECT_EQ(EncodeSampleSet(plain, true)[8] & 0x04, 0);
  // An empty half-vector set keeps its flag.
  SampleSet empty;
  empty.half_vector = true;
  auto decoded_empty = DecodeSampleSet(EncodeSampleSet(empty, true));
  ASSERT_TRUE(decoded_empty.ok()) << decoded_empty.status();
  EXPECT_TRUE(decoded_empty->half_vector);
}

// Version 2 (before the half-vector geometry) is still read: cache entries
// written by an earlier build stay hits. The flag of version 3 in a version 2
// header is an error.
TEST(SampleSetEncoding, VersionTwoIsStillRead) {
  const SampleSet set = MakeSet(4, 50, 11);
  std::string v2 = EncodeSampleSet(set, true);
  ASSERT_EQ(v2[4], 3);
  v2[4] = 2;
  auto decoded = DecodeSampleSet(v2);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_FALSE(decoded->half_vector);
  ExpectSameLayout(set, *decoded);
  v2[8] |= 0x04;
  ExpectDataLoss(v2, "unknown flags 0x5 for version 2");
  // A version 3 buffer whose flag says half-vector but whose arrays lack it.
  std::string missing = EncodeSampleSet(set, true);
  missing[8] |= 0x04;
  ExpectDataLoss(missing, "samples x");
}

// The header alone (what a Sample-cache hit reports): the counts, lights and
// flags DecodeSampleSet reads, and the same DATA_LOSS for a bad prefix.
TEST(SampleSetEncoding, HeaderAgreesWithTheDecodedSet) {
  for (bool compact : {false, true}) {
    for (const SampleSet& set : {MakeSet(3, 40, 7), MakeHalfVectorSet(5, 30, 9), SampleSet{}}) {
      const std::string bytes = EncodeSampleSet(set, compact);
      auto header = ReadSampleSetHeader(bytes);
      ASSERT_TRUE(header.ok()) << header.status();
      auto decoded = DecodeSampleSet(bytes);
      ASSERT_TRUE(decoded.ok()) << decoded.status();
      EXPECT_EQ(header->num_samples, decoded->size());
      EXPECT_EQ(header->num_terms, decoded->light.size());
      EXPECT_EQ(header->light_names, decoded->light_names);
      EXPECT_EQ(header->half_vector, decoded->half_vector);
      EXPECT_EQ(header->has_falloff, !decoded->falloff.empty());
      EXPECT_EQ(header->compact, compact);
    }
  }
  const std::string bytes = EncodeSampleSet(MakeSet(2, 3, 5), true);
  for (size_t n = 0; n < bytes.size(); ++n) {
    auto header = ReadSampleSetHeader(absl::string_view(bytes.data(), n));
    ASSERT_FALSE(header.ok()) << "prefix " << n;
    EXPECT_EQ(header.status().code(), absl::StatusCode::kDataLoss) << header.status();
  }
  EXPECT_FALSE(ReadSampleSetHeader(bytes + "x").ok());  // a trailing byte
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
