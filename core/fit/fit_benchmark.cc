// Timings of the fitting stage (reported, not asserted):
//   FitPhong, LM and Powell, 1e4 / 1e5 / 1e6 samples with 4 lights, RGB;
//   SolveDiffuse throughput over the same sets (per-element closed form);
//   the Phong residual and Jacobian alone, block by block as Ceres calls it
//   (PhongBlockCost, blocks of 1024 like FitPhong), with a flop estimate;
//   the per-texel kd pass over a 512^2 atlas with ~10 observations a texel;
//   issue #13: assembling texel Samples (ForEachTexelSample over a shadow
//   atlas of ceil(L/16) channels, ApplyLightMask per frame) and fitting them
//   (FitPhong LM) at 96 and 256 candidate lights, OLAT (one light on per
//   frame) and dense (16 on), with the Samples' bytes, the bytes the dense
//   layout of encoding v1 would have taken, and the process's peak RSS.
// Run: scripts/bench-micro (JSON into out/bench/), or
//      ninja -C build fit_benchmark && build/core/fit/fit_benchmark
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "benchmark/benchmark.h"
#include "core/fit/diffuse.h"
#include "core/fit/fit_test_util.h"
#include "core/fit/light_sweep.h"
#include "core/fit/phong_cost.h"
#include "core/fit/phong_fit.h"
#include "core/fit/phong_terms.h"
#include "core/samples/assemble.h"

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
    absl::StatusOr<PhongFitResult> result = FitPhong(set, {}, samples::LightMask::FromBits(0xF), options);
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
    DiffuseSolution solution =
        SolveDiffuse(set, samples::LightMask::FromBits(0xF), specular, kElements, DiffuseOptions());
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
      accumulator.Add(set.element[i], set.reflectance[i], set.Illumination(i, samples::LightMask::FromBits(0xF)));
    DiffuseSolution solution = accumulator.Solve(DiffuseOptions());
    benchmark::DoNotOptimize(solution);
  }
  state.counters["samples_per_s"] =
      benchmark::Counter(static_cast<double>(set.size()), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_DiffuseAccumulator)->Arg(1000000)->Unit(benchmark::kMillisecond);

// --- The Phong residual and Jacobian alone -------------------------------

// One channel's normalised data built the way FitPhong's Prepare/SetUpChannel
// build it (clamped cosines, ln h or kNoHighlight, w_k = I_k / I_max, r /
// r_scale), for the evaluation benchmarks only.
struct ChannelProblem {
  internal::PhongTerms terms;
  internal::PhongChannelData data;
  size_t highlight_terms = 0;  // (i, k) pairs with h > 0: the exp() calls per evaluation
};

std::unique_ptr<ChannelProblem> MakeChannelProblem(const samples::SampleSet& set, int c) {
  auto problem = std::make_unique<ChannelProblem>();
  const int num_lights = set.num_lights();
  internal::PhongChannelData& data = problem->data;
  double i_max = 0.0;
  for (int k = 0; k < num_lights; ++k) i_max = std::max(i_max, static_cast<double>(set.light_intensity[k][c]));
  for (int k = 0; k < num_lights; ++k) data.weight.push_back(set.light_intensity[k][c] / i_max);
  data.r.resize(set.size());
  data.diffuse.resize(set.size());
  double sum_rr = 0.0;
  for (size_t i = 0; i < set.size(); ++i) {
    double g_sum = 0.0;
    for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) {
      const int k = set.light[j];
      const double g = internal::ClampedCosine(set.g[j]);
      const double h = internal::ClampedHighlight(g, set.h[j]);
      g_sum += data.weight[k] * g;
      if (h > 0.0) {
        problem->terms.slot.push_back(static_cast<uint16_t>(k));
        problem->terms.log_h.push_back(std::log(h));
        ++problem->highlight_terms;
      }
    }
    problem->terms.begin.push_back(problem->terms.slot.size());
    data.r[i] = set.reflectance[i][c];
    data.diffuse[i] = g_sum;
    sum_rr += data.r[i] * data.r[i];
  }
  const double r_scale = std::sqrt(sum_rr / static_cast<double>(set.size()));
  for (double& r : data.r) r /= r_scale;
  problem->terms.Attach(&data);
  return problem;
}

// Arithmetic per evaluation, exp() not counted (phong_cost.cc): per light
// with h > 0, ke ln h, w exp(.), S +=, D += p ln h: 5 flops and one exp();
// per sample, a G + b S and r - f: 4, and the Jacobian's -b D ke: 2. (D is
// accumulated whether or not the Jacobian is asked for.)
double FlopsPerEvaluation(const ChannelProblem& problem, bool jacobian) {
  return 5.0 * static_cast<double>(problem.highlight_terms) +
         (jacobian ? 6.0 : 4.0) * static_cast<double>(problem.data.size());
}

// Arg 0: samples; arg 1: 1 with the Jacobian, 0 residuals only; arg 2: the
// exponent ke of the data and of the evaluation point.
void BM_PhongResidualBlocks(benchmark::State& state) {
  const size_t count = static_cast<size_t>(state.range(0));
  const bool with_jacobian = state.range(1) != 0;
  const double ke = static_cast<double>(state.range(2));
  static std::map<std::pair<size_t, int64_t>, samples::SampleSet> sets;
  auto key = std::make_pair(count, state.range(2));
  if (sets.find(key) == sets.end()) {
    testing::GeneratorOptions generator;
    generator.num_samples = count;
    generator.num_lights = 4;
    generator.noise = 0.05;
    sets.emplace(key,
                 testing::MakeSamples(testing::MakePhong({0.5, 0.3, 0.2}, {0.3, 0.6, 0.15}, {ke, ke, ke}), generator));
  }
  const std::unique_ptr<ChannelProblem> problem = MakeChannelProblem(sets.at(key), 0);
  // The blocks FitPhong hands to Ceres (kBlockSize = 1024 in phong_fit.cc).
  constexpr size_t kBlock = 1024;
  std::vector<std::unique_ptr<ceres::CostFunction>> blocks;
  for (size_t begin = 0; begin < count; begin += kBlock) {
    blocks.emplace_back(internal::PhongBlockCost::Create(&problem->data, begin, std::min(count, begin + kBlock)));
  }
  double x[3] = {1.0, 1.0, std::log(ke)};
  const double* parameters[1] = {x};
  std::vector<double> residuals(kBlock), jacobian(3 * kBlock);
  double* jacobians[1] = {jacobian.data()};
  for (auto _ : state) {
    for (const auto& block : blocks) {
      block->Evaluate(parameters, residuals.data(), with_jacobian ? jacobians : nullptr);
      benchmark::DoNotOptimize(residuals.data());
      benchmark::DoNotOptimize(jacobian.data());
    }
    benchmark::ClobberMemory();
  }
  state.SetLabel(with_jacobian ? "residual+jacobian" : "residual");
  state.counters["samples_per_s"] =
      benchmark::Counter(static_cast<double>(count), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["exp_per_s"] =
      benchmark::Counter(static_cast<double>(problem->highlight_terms), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["flops_per_s"] =
      benchmark::Counter(FlopsPerEvaluation(*problem, with_jacobian), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["exp_per_sample"] = static_cast<double>(problem->highlight_terms) / static_cast<double>(count);
}
BENCHMARK(BM_PhongResidualBlocks)
    ->ArgsProduct({{100000}, {0, 1}, {40, 1000}})
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);

// --- The per-texel kd pass -----------------------------------------------

// A 512^2 atlas, ~10 observations a texel (element = sample % texels).
constexpr uint32_t kTexels = 512 * 512;
constexpr size_t kTexelSamples = 10 * static_cast<size_t>(kTexels);

const samples::SampleSet& TexelSamples() {
  static const samples::SampleSet set = [] {
    testing::GeneratorOptions generator;
    generator.num_samples = kTexelSamples;
    generator.num_lights = 4;
    generator.num_elements = kTexels;
    generator.noise = 0.05;
    return testing::MakeSamples(testing::MakePhong({0.5, 0.3, 0.2}, {0.3, 0.6, 0.15}, {40, 40, 40}), generator);
  }();
  return set;
}

// Inputs of Add() precomputed, so that this is Add + Solve alone.
struct TexelInputs {
  std::vector<uint32_t> element;
  std::vector<glm::vec3> residual, illumination;
};

const TexelInputs& TexelAddInputs() {
  static const TexelInputs inputs = [] {
    const samples::SampleSet& set = TexelSamples();
    TexelInputs in;
    in.element = set.element;
    in.residual = set.reflectance;
    in.illumination.resize(set.size());
    for (size_t i = 0; i < set.size(); ++i) in.illumination[i] = set.Illumination(i, samples::LightMask::FromBits(0xF));
    return in;
  }();
  return inputs;
}

void BM_TexelAccumulateAndSolve(benchmark::State& state) {
  const TexelInputs& in = TexelAddInputs();
  for (auto _ : state) {
    DiffuseAccumulator accumulator(kTexels);
    for (size_t i = 0; i < in.element.size(); ++i) accumulator.Add(in.element[i], in.residual[i], in.illumination[i]);
    DiffuseSolution solution = accumulator.Solve(DiffuseOptions());
    benchmark::DoNotOptimize(solution);
  }
  state.counters["observations_per_s"] =
      benchmark::Counter(static_cast<double>(in.element.size()), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["texels_per_s"] =
      benchmark::Counter(static_cast<double>(kTexels), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_TexelAccumulateAndSolve)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);

// Solve() alone over the filled accumulator (allocation of the solution included).
void BM_TexelSolve(benchmark::State& state) {
  const TexelInputs& in = TexelAddInputs();
  DiffuseAccumulator accumulator(kTexels);
  for (size_t i = 0; i < in.element.size(); ++i) accumulator.Add(in.element[i], in.residual[i], in.illumination[i]);
  for (auto _ : state) {
    DiffuseSolution solution = accumulator.Solve(DiffuseOptions());
    benchmark::DoNotOptimize(solution);
  }
  state.counters["texels_per_s"] =
      benchmark::Counter(static_cast<double>(kTexels), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_TexelSolve)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);

// SolveDiffuse over the same atlas (specular removal with exp() included);
// arg: threads.
void BM_TexelSolveDiffuse(benchmark::State& state) {
  const samples::SampleSet& set = TexelSamples();
  const PhongRgb specular = testing::MakePhong({0, 0, 0}, {0.3, 0.6, 0.15}, {40, 40, 40});
  const int threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    DiffuseSolution solution =
        SolveDiffuse(set, samples::LightMask::FromBits(0xF), specular, kTexels, DiffuseOptions(), threads);
    benchmark::DoNotOptimize(solution);
  }
  state.counters["observations_per_s"] =
      benchmark::Counter(static_cast<double>(set.size()), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["texels_per_s"] =
      benchmark::Counter(static_cast<double>(kTexels), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_TexelSolveDiffuse)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Repetitions(3)
    ->ReportAggregatesOnly(true);

// Issue #13: a 32 x 32 texel patch of the plane z = 0 (normals tilted per
// texel), seen from above, under `lights` point lights on a ring; L frames,
// frame f with lights f, f + L/16, ... on (OLAT: light f alone). Every light
// is visible from every texel in the shadow atlas; the frame's mask clears
// the others (FrameStream's ApplyLightMask).
struct ManyLightScene {
  cv::Mat resampled;
  resample::GeometryAtlas geometry;
  cv::Mat shadows;
  scene::CameraModel camera;
  std::vector<scene::Light> lights;
};

constexpr int kPatch = 32;

ManyLightScene MakeManyLightScene(int num_lights) {
  ManyLightScene s;
  s.resampled = cv::Mat(kPatch, kPatch, CV_32FC4, cv::Scalar(0.3, 0.3, 0.3, 1.0));
  s.geometry.position = cv::Mat(kPatch, kPatch, CV_32FC4);
  s.geometry.normal = cv::Mat(kPatch, kPatch, CV_32FC4);
  for (int r = 0; r < kPatch; ++r) {
    for (int c = 0; c < kPatch; ++c) {
      s.geometry.position.at<cv::Vec4f>(r, c) = {(c + 0.5f) / kPatch, (r + 0.5f) / kPatch, 0.0f, 1.0f};
      const glm::vec3 n = glm::normalize(glm::vec3(0.3f * std::sin(0.7f * c), 0.3f * std::cos(0.5f * r), 1.0f));
      s.geometry.normal.at<cv::Vec4f>(r, c) = {n.x, n.y, n.z, 1.0f};
    }
  }
  s.shadows = cv::Mat(kPatch, kPatch, samples::ShadowAtlasType(static_cast<size_t>(num_lights)), cv::Scalar::all(0));
  for (int r = 0; r < kPatch; ++r) {
    for (int c = 0; c < kPatch; ++c) {
      for (int k = 0; k < num_lights; ++k) samples::SetShadowBit(&s.shadows, r, c, static_cast<size_t>(k));
    }
  }
  s.camera.name = "above";
  s.camera.width = s.camera.height = 64;
  s.camera.fx = s.camera.fy = 64;
  s.camera.cx = s.camera.cy = 31.5;
  s.camera.cam_from_world_rotation = glm::dmat3(glm::dvec3(1, 0, 0), glm::dvec3(0, -1, 0), glm::dvec3(0, 0, -1));
  s.camera.cam_from_world_translation = -(s.camera.cam_from_world_rotation * glm::dvec3(0.5, 0.5, 3.0));
  for (int k = 0; k < num_lights; ++k) {
    scene::Light l;
    l.name = "L" + std::to_string(k);
    const float angle = 6.2831853f * static_cast<float>(k) / static_cast<float>(num_lights);
    const float height = 0.5f + 2.0f * static_cast<float>(k % 7) / 7.0f;
    l.position = {0.5f + 1.5f * std::cos(angle), 0.5f + 1.5f * std::sin(angle), height};
    l.intensity = glm::vec3(1.0f + 0.002f * static_cast<float>(k));
    s.lights.push_back(l);
  }
  return s;
}

int64_t PeakRssBytes() {
  struct rusage usage;
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<int64_t>(usage.ru_maxrss) * 1024;
}

// Args: candidate lights, lights on per frame. One iteration assembles L
// frames of texel Samples and fits them (LM, all lights in the mask).
void BM_AssembleAndFitManyLights(benchmark::State& state) {
  const int num_lights = static_cast<int>(state.range(0));
  const int on = static_cast<int>(state.range(1));
  const ManyLightScene s = MakeManyLightScene(num_lights);
  const PhongRgb truth = testing::MakePhong({0.5, 0.3, 0.2}, {0.3, 0.6, 0.15}, {40, 40, 40});
  const samples::LightMask all = samples::AllLights(static_cast<size_t>(num_lights));
  double assemble_seconds = 0.0, fit_seconds = 0.0;
  size_t sample_bytes = 0, samples_count = 0, terms = 0;
  double kd_error = 0.0;
  for (auto _ : state) {
    auto t0 = std::chrono::steady_clock::now();
    samples::SampleSet set = samples::MakeSampleSet(s.lights);
    for (int f = 0; f < num_lights; ++f) {
      samples::LightMask frame_on;
      for (int m = 0; m < on; ++m) frame_on.Set(static_cast<size_t>((f + m * (num_lights / on)) % num_lights));
      cv::Mat shadows = s.shadows.clone();
      samples::ApplyLightMask(frame_on, static_cast<size_t>(num_lights), &shadows);
      samples::ForEachTexelSample(s.resampled, s.geometry, shadows, s.camera, s.lights, samples::AssembleOptions{},
                                  [&](uint32_t texel, const glm::vec3& rgb, const samples::LightTerms& t) {
                                    set.AddTerms(texel, f, 0, rgb, t.count, t.light, t.g, t.h);
                                  });
    }
    auto t1 = std::chrono::steady_clock::now();
    // Reflectance from the truth, so that the fit has something to recover.
    for (size_t i = 0; i < set.size(); ++i) {
      for (int c = 0; c < 3; ++c) set.reflectance[i][c] = static_cast<float>(EvaluateSample(set, i, all, truth[c], c));
    }
    auto t2 = std::chrono::steady_clock::now();
    absl::StatusOr<PhongFitResult> result = FitPhong(set, {}, all, PhongFitOptions());
    auto t3 = std::chrono::steady_clock::now();
    if (!result.ok()) {
      state.SkipWithError(std::string(result.status().message()).c_str());
      return;
    }
    assemble_seconds += std::chrono::duration<double>(t1 - t0).count();
    fit_seconds += std::chrono::duration<double>(t3 - t2).count();
    sample_bytes = set.MemoryBytes();
    samples_count = set.size();
    terms = set.num_terms();
    kd_error = std::fabs(result->params[0].kd - truth[0].kd) / truth[0].kd;
    benchmark::DoNotOptimize(result);
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["assemble_s"] = assemble_seconds / n;
  state.counters["fit_s"] = fit_seconds / n;
  state.counters["samples"] = static_cast<double>(samples_count);
  state.counters["terms"] = static_cast<double>(terms);
  state.counters["sample_bytes"] = static_cast<double>(sample_bytes);
  // Encoding v1's in-memory layout: 19 bytes per sample + g and h per light.
  state.counters["dense_bytes"] = static_cast<double>(samples_count) * (19.0 + 8.0 * num_lights);
  state.counters["peak_rss_bytes"] = static_cast<double>(PeakRssBytes());
  state.counters["kd_rel_error"] = kd_error;
}
BENCHMARK(BM_AssembleAndFitManyLights)
    ->Args({96, 1})
    ->Args({96, 16})
    ->Args({256, 1})
    ->Args({256, 16})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

// One light configuration of the sweep (SweepConfigurations on one thread, as
// a service sweep task runs it): FitPhong on a 1e5 subsample, E_a over every
// Sample, the robust per-triangle kd (E_d) and the held-out error, on 2e6
// Samples of 9 lights (4 on each), 20 000 triangles, 40 frames, robust
// (Cauchy) like `mvbrdf run`. Argument: the configuration's light count.
void BM_SweepConfiguration(benchmark::State& state) {
  constexpr uint32_t kTriangles = 20000;
  static const samples::SampleSet set = [] {
    samples::SampleSet s = testing::MakeManyLightSamples(
        testing::MakePhong({0.4, 0.3, 0.2}, {0.3, 0.25, 0.2}, {30, 35, 40}), 9, 4, 2000000, kTriangles);
    for (size_t i = 0; i < s.size(); ++i) s.frame[i] = static_cast<uint16_t>(i * 40 / s.size());
    return s;
  }();
  LightConfiguration configuration{"config", {}};
  for (int k = 0; k < state.range(0); ++k) configuration.lights.push_back(set.light_names[static_cast<size_t>(k)]);
  PhongFitOptions fit_options;
  DiffuseOptions diffuse_options;
  fit_options.robust.loss = diffuse_options.robust.loss = RobustLoss::kCauchy;
  for (auto _ : state) {
    absl::StatusOr<SweepResult> result =
        SweepConfigurations(set, kTriangles, {configuration}, fit_options, diffuse_options, 1, 100000);
    if (!result.ok()) state.SkipWithError(std::string(result.status().message()).c_str());
    benchmark::DoNotOptimize(result);
  }
}
BENCHMARK(BM_SweepConfiguration)
    ->Arg(4)
    ->Arg(9)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);

}  // namespace
}  // namespace mvbrdf::fit

BENCHMARK_MAIN();
