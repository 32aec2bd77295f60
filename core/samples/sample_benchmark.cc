// Throughput of the SampleSet encoding (reported, not asserted): the cache
// and wire format of issue #5. EncodeSampleSet compact (f16 reals) and exact
// (f32 reals) and DecodeSampleSet of each, for 1e6 samples with 4 lights,
// without and with the fall-off array. Bytes/s count the encoded buffer
// (written by Encode, read by Decode); `in_memory_bytes` is
// SampleSet::MemoryBytes() for comparison.
// Run: scripts/bench-micro (JSON into out/bench/), or
//      ninja -C build sample_benchmark && build/core/samples/sample_benchmark
#include <cstdint>
#include <map>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "benchmark/benchmark.h"
#include "core/base/draw_order.h"
#include "core/samples/sample_set.h"

namespace mvbrdf::samples {
namespace {

constexpr int kLights = 4;

// Random but plausible samples: a 512^2 atlas of elements, 60 frames, 8
// cameras, g and h in [0, 1] (h = 0 where g = 0), reflectances in [0, 2].
SampleSet MakeRandomSet(size_t count, bool falloff) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  SampleSet set;
  for (int k = 0; k < kLights; ++k) {
    set.light_names.push_back("L" + std::to_string(k));
    set.light_intensity.push_back(glm::vec3(1.0f + static_cast<float>(k), 2.0f, 0.5f));
  }
  float g[kLights], h[kLights], a[kLights];
  for (size_t i = 0; i < count; ++i) {
    for (int k = 0; k < kLights; ++k) {
      g[k] = unit(rng) < 0.2f ? 0.0f : unit(rng);
      h[k] = g[k] > 0.0f ? unit(rng) : 0.0f;
      a[k] = 0.1f + unit(rng);
    }
    const glm::vec3 rgb = base::DrawVec3<glm::vec3>([&] { return 2.0f * unit(rng); });
    set.Add(static_cast<uint32_t>(i % (512 * 512)), static_cast<int>(i % 60), static_cast<int>(i % 8), rgb, g, h,
            falloff ? a : nullptr);
  }
  return set;
}

const SampleSet& Set(size_t count, bool falloff) {
  static std::map<std::tuple<size_t, bool>, SampleSet> cache;
  auto key = std::make_tuple(count, falloff);
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, MakeRandomSet(count, falloff)).first;
  return it->second;
}

// Arg 0: samples; arg 1: compact (1) or exact (0); arg 2: fall-off array (1) or not.
void BM_EncodeSampleSet(benchmark::State& state) {
  const SampleSet& set = Set(static_cast<size_t>(state.range(0)), state.range(2) != 0);
  const bool compact = state.range(1) != 0;
  size_t bytes = 0;
  for (auto _ : state) {
    std::string encoded = EncodeSampleSet(set, compact);
    bytes = encoded.size();
    benchmark::DoNotOptimize(encoded);
  }
  state.SetLabel(compact ? "compact" : "exact");
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * bytes));
  state.counters["encoded_bytes"] = static_cast<double>(bytes);
  state.counters["in_memory_bytes"] = static_cast<double>(set.MemoryBytes());
  state.counters["samples_per_s"] =
      benchmark::Counter(static_cast<double>(set.size()), benchmark::Counter::kIsIterationInvariantRate);
}

void BM_DecodeSampleSet(benchmark::State& state) {
  const SampleSet& set = Set(static_cast<size_t>(state.range(0)), state.range(2) != 0);
  const bool compact = state.range(1) != 0;
  const std::string encoded = EncodeSampleSet(set, compact);
  for (auto _ : state) {
    absl::StatusOr<SampleSet> decoded = DecodeSampleSet(encoded);
    if (!decoded.ok()) {
      state.SkipWithError(std::string(decoded.status().message()).c_str());
      break;
    }
    benchmark::DoNotOptimize(decoded);
  }
  state.SetLabel(compact ? "compact" : "exact");
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * encoded.size()));
  state.counters["encoded_bytes"] = static_cast<double>(encoded.size());
  state.counters["samples_per_s"] =
      benchmark::Counter(static_cast<double>(set.size()), benchmark::Counter::kIsIterationInvariantRate);
}

BENCHMARK(BM_EncodeSampleSet)
    ->ArgsProduct({{1000000}, {1, 0}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);
BENCHMARK(BM_DecodeSampleSet)
    ->ArgsProduct({{1000000}, {1, 0}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);

}  // namespace
}  // namespace mvbrdf::samples

BENCHMARK_MAIN();
