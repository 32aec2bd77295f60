// Timings of the fitting stage (reported, not asserted):
//   FitPhong, LM and Powell, 1e4 / 1e5 / 1e6 samples with 4 lights, RGB;
//   SolveDiffuse throughput over the same sets (per-element closed form).
// Run: ninja -C build-fit fit_benchmark && build-fit/core/fit/fit_benchmark
#include <map>

#include "benchmark/benchmark.h"
#include "core/fit/diffuse.h"
#include "core/fit/fit_test_util.h"
#include "core/fit/phong_fit.h"

namespace mvbrdf::fit {
namespace {

constexpr uint32_t kElements = 10000;

const samples::SampleSet& Samples(size_t count) {
  static std::map<size_t, samples::SampleSet> cache;
  auto it = cache.find(count);
  if (it == cache.end()) {
    testing::GeneratorOptions generator;
    generator.num_samples = count;
    generator.num_lights = 4;
    generator.num_elements = kElements;
    generator.noise = 0.05;
    const PhongRgb truth = testing::MakePhong({0.5, 0.3, 0.2}, {0.3, 0.6, 0.15}, {40, 40, 40});
    it = cache.emplace(count, testing::MakeSamples(truth, generator)).first;
  }
  return it->second;
}

void BM_FitPhong(benchmark::State& state) {
  const samples::SampleSet& set = Samples(static_cast<size_t>(state.range(0)));
  PhongFitOptions options;
  options.solver = state.range(1) == 0 ? Solver::kLevenbergMarquardt : Solver::kPowell;
  int iterations = 0;
  double cost = 0.0;
  for (auto _ : state) {
    absl::StatusOr<PhongFitResult> result = FitPhong(set, {}, 0xF, options);
    benchmark::DoNotOptimize(result);
    iterations = result->channels[0].iterations + result->channels[1].iterations + result->channels[2].iterations;
    cost = result->channels[0].final_cost + result->channels[1].final_cost + result->channels[2].final_cost;
  }
  state.SetLabel(SolverName(options.solver));
  state.counters["solver_iterations_rgb"] = iterations;
  state.counters["final_cost_rgb"] = cost;
  state.counters["samples_per_s"] =
      benchmark::Counter(static_cast<double>(set.size()), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_FitPhong)
    ->ArgsProduct({{10000, 100000, 1000000}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3)
    ->ReportAggregatesOnly(true);

void BM_SolveDiffuse(benchmark::State& state) {
  const samples::SampleSet& set = Samples(static_cast<size_t>(state.range(0)));
  const PhongRgb specular = testing::MakePhong({0, 0, 0}, {0.3, 0.6, 0.15}, {40, 40, 40});
  for (auto _ : state) {
    DiffuseSolution solution = SolveDiffuse(set, 0xF, specular, kElements, DiffuseOptions());
    benchmark::DoNotOptimize(solution);
  }
  state.counters["samples_per_s"] =
      benchmark::Counter(static_cast<double>(set.size()), benchmark::Counter::kIsIterationInvariantRate);
  // Bytes read: reflectance (12) + g and h for 4 lights (32) + element (4).
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * set.size() * 48));
}
BENCHMARK(BM_SolveDiffuse)->Arg(1000000)->Unit(benchmark::kMillisecond);

// The accumulate-and-solve core alone (no specular exp): the streaming bound.
void BM_DiffuseAccumulator(benchmark::State& state) {
  const samples::SampleSet& set = Samples(static_cast<size_t>(state.range(0)));
  for (auto _ : state) {
    DiffuseAccumulator accumulator(kElements);
    for (size_t i = 0; i < set.size(); ++i)
      accumulator.Add(set.element[i], set.reflectance[i], set.Illumination(i, 0xF));
    DiffuseSolution solution = accumulator.Solve(DiffuseOptions());
    benchmark::DoNotOptimize(solution);
  }
  state.counters["samples_per_s"] =
      benchmark::Counter(static_cast<double>(set.size()), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_DiffuseAccumulator)->Arg(1000000)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace mvbrdf::fit

BENCHMARK_MAIN();
