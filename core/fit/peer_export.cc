// fit_peer: the C++ half of the SciPy peer comparison (scripts/bench-peer).
//
// Builds a few synthetic Phong problems with the test generator
// (fit_test_util), fits each with our FitPhong — Levenberg-Marquardt and
// Powell, single-threaded, default PhongFitOptions — timing the fits (median
// of `--repeats` runs), and writes for each problem the raw inputs the fitter
// reads, so that scripts/peer_scipy.py can fit the same model with
// scipy.optimize.least_squares and compare time and final cost:
//
//   DIR/NAME/reflectance.f64   N x 3   linear RGB (the float samples, widened)
//   DIR/NAME/g.f64             N x L   raw g (unclamped, as stored)
//   DIR/NAME/h.f64             N x L   raw h
//   DIR/NAME/falloff.f64       N x L   a_k, only when the set has fall-off
//   DIR/NAME/intensity.f64     L x 3   I_kc
//   DIR/manifest.json          problems, options (bounds, initial values,
//                              tolerances), and our results per solver:
//                              params, initial/final cost per channel
//                              (0.5 * sum of squared residuals, original
//                              units), iterations, flags, seconds; and
//                              the same problem through Ceres's LM, as
//                              FitPhong solved it before the fused LM
//                              (evaluation counts and times, see below)
//
// All .f64 files are little-endian float64, row-major. The clamping of g and
// h, the fall-off, the normalisation (I_max, r_scale), the log-ke
// parametrisation and the bounds are NOT exported pre-applied: the peer
// re-implements them from phong_fit.cc, and checks itself by evaluating our
// final parameters and comparing with our reported cost.
//
// Usage: fit_peer --out DIR [--repeats 3]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "ceres/ceres.h"
#include "core/fit/fit_test_util.h"
#include "core/fit/phong_cost.h"
#include "core/fit/phong_fit.h"
#include "core/fit/phong_terms.h"

namespace mvbrdf::fit {
namespace {

struct Problem {
  std::string name;
  std::string description;
  PhongRgb truth;
  samples::SampleSet set;
  samples::LightMask mask;
};

// Our model (EvaluateSample, which honours fall-off) plus Gaussian noise of
// sigma = noise * mean per channel: the generator's reflectances recomputed
// after the intensities or fall-off were changed.
void RecomputeReflectance(const PhongRgb& truth, const samples::LightMask& mask, double noise, uint64_t seed,
                          samples::SampleSet* set) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  std::vector<glm::dvec3> values(set->size());
  glm::dvec3 mean(0.0);
  for (size_t i = 0; i < set->size(); ++i) {
    for (int c = 0; c < 3; ++c) values[i][c] = EvaluateSample(*set, i, mask, truth[c], c);
    mean += values[i] / static_cast<double>(set->size());
  }
  for (size_t i = 0; i < set->size(); ++i) {
    glm::dvec3 r = values[i];
    for (int c = 0; c < 3; ++c) r[c] += noise * mean[c] * normal(rng);
    set->reflectance[i] = glm::vec3(r);
  }
}

std::vector<Problem> MakeProblems() {
  std::vector<Problem> problems;
  const auto add = [&](const std::string& name, const std::string& description, const PhongRgb& truth, size_t count,
                       double noise) -> Problem& {
    testing::GeneratorOptions generator;
    generator.num_samples = count;
    generator.num_lights = 4;
    generator.num_elements = 1;
    generator.noise = noise;
    generator.seed = 17 + problems.size();
    problems.push_back(
        Problem{name, description, truth, testing::MakeSamples(truth, generator), samples::LightMask::FromBits(0xF)});
    return problems.back();
  };
  const PhongRgb ke40 = testing::MakePhong({0.5, 0.3, 0.2}, {0.3, 0.6, 0.15}, {40, 40, 40});
  add("n1e4_ke40", "1e4 samples, 4 lights, ke = 40, noise 5%", ke40, 10000, 0.05);
  add("n1e5_ke40", "1e5 samples, 4 lights, ke = 40, noise 5%", ke40, 100000, 0.05);
  add("n1e5_ke1000", "1e5 samples, 4 lights, ke = 1000, noise 5%",
      testing::MakePhong({0.5, 0.3, 0.2}, {0.3, 0.6, 0.15}, {1000, 1000, 1000}), 100000, 0.05);
  add("n1e5_noisy", "1e5 samples, 4 lights, ke = 40, noise 30%", ke40, 100000, 0.30);
  add("n1e4_mixed_ke", "1e4 samples, 4 lights, ke = 5 / 200 / 3000 per channel, noise 2%",
      testing::MakePhong({0.5, 0.3, 0.2}, {0.3, 0.6, 0.15}, {5, 200, 3000}), 10000, 0.02);
  {
    // Unequal RGB intensities, 3 of the 4 lights, inverse-square fall-off
    // a_k in [0.1, 1]: every branch of the normalisation and of the
    // specular term.
    Problem& p = add("n1e5_falloff", "1e5 samples, lights 0-2 of 4, unequal RGB intensities, fall-off, noise 5%", ke40,
                     100000, 0.0);
    p.mask = samples::LightMask::FromBits(0x7);
    p.set.light_intensity = {glm::vec3(2.0f, 1.0f, 0.5f), glm::vec3(0.5f, 1.5f, 1.0f), glm::vec3(1.0f, 1.0f, 3.0f),
                             glm::vec3(4.0f, 4.0f, 4.0f)};
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<float> uniform(0.1f, 1.0f);
    p.set.falloff.resize(p.set.g.size());
    for (float& a : p.set.falloff) a = uniform(rng);
    RecomputeReflectance(p.truth, p.mask, 0.05, 6, &p.set);
  }
  return problems;
}

// Sample x light rows of a per-term array (SampleSet's CSR), `absent` where a
// light does not reach a sample: the peers read dense rows.
std::vector<double> DenseRows(const samples::SampleSet& set, const std::vector<float>& terms, double absent) {
  const size_t num = static_cast<size_t>(set.num_lights());
  std::vector<double> rows(set.size() * num, absent);
  for (size_t i = 0; i < set.size(); ++i) {
    for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) rows[i * num + set.light[j]] = terms[j];
  }
  return rows;
}

bool WriteF64(const std::filesystem::path& path, const std::vector<double>& values) {
  std::ofstream out(path, std::ios::binary);
  // Little-endian hosts only (x86-64, aarch64): the doubles are written as is.
  static_assert(sizeof(double) == 8);
  out.write(reinterpret_cast<const char*>(values.data()), static_cast<std::streamsize>(values.size() * 8));
  return static_cast<bool>(out);
}

std::string Num(double v) {
  if (!std::isfinite(v)) return "null";
  return absl::StrFormat("%.17g", v);
}

struct Timed {
  PhongFitResult result;
  std::vector<double> seconds;  // every repeat
  double median = 0.0;
};

Timed TimeFit(const Problem& p, Solver solver, int repeats) {
  PhongFitOptions options;
  options.solver = solver;
  options.parallel_channels = false;  // single-threaded, as the peer is
  Timed timed;
  for (int r = 0; r < repeats; ++r) {
    const auto start = std::chrono::steady_clock::now();
    absl::StatusOr<PhongFitResult> result = FitPhong(p.set, {}, p.mask, options);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!result.ok()) {
      std::fprintf(stderr, "fit_peer: %s: %s\n", p.name.c_str(), std::string(result.status().message()).c_str());
      std::exit(1);
    }
    timed.result = *result;
    timed.seconds.push_back(seconds);
  }
  std::vector<double> sorted = timed.seconds;
  std::sort(sorted.begin(), sorted.end());
  timed.median = sorted[sorted.size() / 2];
  return timed;
}

// The same problem through Ceres's LM, as FitPhong solved it before its
// fused LM (core/fit/phong_lm.h): a copy of what phong_fit.cc's Prepare and
// FitChannel (now SetUpChannel / SolveChannel) did for the case of every
// parameter free, which all these problems are, from the options' initial
// point (not FitPhong's grid), with Ceres's evaluation counts and times per
// channel. Its final cost is reported beside
// FitPhong's.
//
// With `projected_line_search` false, the same solve with Ceres's projected
// line search after each bounded trust-region step turned off
// (max_num_line_search_step_size_iterations = 0; the bounds still hold, by
// projection in Plus): an experiment, since that line search costs a
// residual + Jacobian evaluation per iteration.
std::string CeresDiagnosticsJson(const Problem& p, bool projected_line_search) {
  const samples::SampleSet& set = p.set;
  const PhongFitOptions options;
  std::vector<int> lights;
  for (int k = 0; k < set.num_lights(); ++k) {
    if (p.mask.Test(static_cast<size_t>(k))) lights.push_back(k);
  }
  const int num_lights = static_cast<int>(lights.size());
  const size_t n = set.size();
  std::vector<double> g(n * num_lights, 0.0), log_h(n * num_lights, internal::kNoHighlight), log_a;
  if (!set.falloff.empty()) log_a.resize(n * num_lights, 0.0);
  for (size_t i = 0; i < n; ++i) {
    for (int m = 0; m < num_lights; ++m) {
      const int k = lights[m];
      for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) {
        if (set.light[j] != k) continue;
        const double gc = internal::ClampedCosine(set.g[j]);
        const double h = internal::ClampedHighlight(gc, set.h[j]);
        g[i * num_lights + m] = gc;
        log_h[i * num_lights + m] = h > 0.0 ? std::log(h) : internal::kNoHighlight;
        if (!log_a.empty()) {
          const double a = set.TermFalloff(j);
          log_a[i * num_lights + m] = a > 0.0 && std::isfinite(a) ? std::log(a) : internal::kNoHighlight;
        }
      }
    }
  }
  internal::PhongTerms terms;
  for (size_t i = 0; i < n; ++i) {
    terms.AddDense(num_lights, log_h.data() + i * num_lights, log_a.empty() ? nullptr : log_a.data() + i * num_lights);
  }
  std::vector<std::string> channels;
  for (int c = 0; c < 3; ++c) {
    internal::PhongChannelData data;
    terms.Attach(&data);
    double i_max = 0.0;
    for (int k : lights) {
      data.weight.push_back(set.light_intensity[k][c]);
      i_max = std::max(i_max, static_cast<double>(set.light_intensity[k][c]));
    }
    for (double& w : data.weight) w /= i_max;
    data.r.resize(n);
    data.diffuse.resize(n);
    double sum_rr = 0.0;
    for (size_t i = 0; i < n; ++i) {
      double g_sum = 0.0;
      for (int m = 0; m < num_lights; ++m) g_sum += data.weight[m] * g[i * num_lights + m];
      data.r[i] = set.reflectance[i][c];
      data.diffuse[i] = g_sum;
      sum_rr += data.r[i] * data.r[i];
    }
    const double r_scale = std::sqrt(sum_rr / static_cast<double>(n));
    for (double& r : data.r) r /= r_scale;
    const double to_original = r_scale / i_max;
    const double lower[3] = {0.0, 0.0, std::log(options.ke_min)};
    const double upper[3] = {options.kd_max / to_original, options.ks_max / to_original, std::log(options.ke_max)};
    double x[3] = {options.initial.kd / to_original, options.initial.ks / to_original, std::log(options.initial.ke)};
    double s_rg = 0.0, s_gg = 0.0;
    for (size_t i = 0; i < n; ++i) {
      s_rg += data.r[i] * data.diffuse[i];
      s_gg += data.diffuse[i] * data.diffuse[i];
    }
    if (s_gg > 0.0) x[0] = s_rg / s_gg;
    for (int j = 0; j < 3; ++j) x[j] = std::clamp(x[j], lower[j], upper[j]);

    ceres::Problem problem;
    for (size_t begin = 0; begin < n; begin += 1024) {
      problem.AddResidualBlock(internal::PhongBlockCost::Create(&data, begin, std::min(n, begin + 1024)), nullptr, x);
    }
    for (int j = 0; j < 3; ++j) {
      problem.SetParameterLowerBound(x, j, lower[j]);
      problem.SetParameterUpperBound(x, j, upper[j]);
    }
    ceres::Solver::Options solver_options;
    solver_options.minimizer_type = ceres::TRUST_REGION;
    solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    solver_options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
    solver_options.max_num_iterations = options.max_iterations;
    solver_options.function_tolerance = options.function_tolerance;
    solver_options.parameter_tolerance = 1e-10;
    solver_options.num_threads = 1;
    solver_options.logging_type = ceres::SILENT;
    if (!projected_line_search) solver_options.max_num_line_search_step_size_iterations = 0;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    channels.push_back(absl::StrCat(
        "{\"final_cost\": ", Num(summary.final_cost * r_scale * r_scale),
        ", \"iterations\": ", summary.num_successful_steps + summary.num_unsuccessful_steps,
        ", \"residual_evaluations\": ", summary.num_residual_evaluations, ", \"jacobian_evaluations\": ",
        summary.num_jacobian_evaluations, ", \"residual_seconds\": ", Num(summary.residual_evaluation_time_in_seconds),
        ", \"jacobian_seconds\": ", Num(summary.jacobian_evaluation_time_in_seconds),
        ", \"linear_solver_seconds\": ", Num(summary.linear_solver_time_in_seconds), ", \"preprocessor_seconds\": ",
        Num(summary.preprocessor_time_in_seconds), ", \"minimizer_seconds\": ", Num(summary.minimizer_time_in_seconds),
        ", \"total_seconds\": ", Num(summary.total_time_in_seconds), ", \"termination\": \"",
        ceres::TerminationTypeToString(summary.termination_type), "\"}"));
  }
  return absl::StrCat("[", absl::StrJoin(channels, ", "), "]");
}

std::string SolverJson(const Timed& t) {
  std::vector<std::string> params, channels;
  for (int c = 0; c < 3; ++c) {
    params.push_back(absl::StrCat("[", Num(t.result.params[c].kd), ", ", Num(t.result.params[c].ks), ", ",
                                  Num(t.result.params[c].ke), "]"));
    const ChannelFitSummary& s = t.result.channels[c];
    channels.push_back(absl::StrCat("{\"initial_cost\": ", Num(s.initial_cost), ", \"final_cost\": ", Num(s.final_cost),
                                    ", \"iterations\": ", s.iterations, ", \"flags\": ", s.flags, ", \"start\": [",
                                    Num(s.start[0]), ", ", Num(s.start[1]), ", ", Num(s.start[2]), "]}"));
  }
  std::vector<std::string> seconds;
  for (double s : t.seconds) seconds.push_back(Num(s));
  return absl::StrCat("{\"seconds\": ", Num(t.median), ", \"seconds_all\": [", absl::StrJoin(seconds, ", "),
                      "], \"samples_used\": ", t.result.samples_used, ", \"params\": [", absl::StrJoin(params, ", "),
                      "], \"channels\": [", absl::StrJoin(channels, ", "), "]}");
}

int Main(int argc, char** argv) {
  std::string out_dir;
  int repeats = 3;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--out") == 0 && i + 1 < argc) {
      out_dir = argv[++i];
    } else if (std::strcmp(argv[i], "--repeats") == 0 && i + 1 < argc) {
      repeats = std::max(1, std::atoi(argv[++i]));
    } else {
      std::fprintf(stderr, "usage: fit_peer --out DIR [--repeats N]\n");
      return 2;
    }
  }
  if (out_dir.empty()) {
    std::fprintf(stderr, "usage: fit_peer --out DIR [--repeats N]\n");
    return 2;
  }
  const PhongFitOptions defaults;
  std::vector<std::string> entries;
  for (const Problem& p : MakeProblems()) {
    const std::filesystem::path dir = std::filesystem::path(out_dir) / p.name;
    std::error_code error;
    std::filesystem::create_directories(dir, error);
    if (error) {
      std::fprintf(stderr, "fit_peer: %s: %s\n", dir.c_str(), error.message().c_str());
      return 4;
    }
    const samples::SampleSet& set = p.set;
    std::vector<double> reflectance, intensity;
    for (const glm::vec3& r : set.reflectance) reflectance.insert(reflectance.end(), {r.x, r.y, r.z});
    for (const glm::vec3& i : set.light_intensity) intensity.insert(intensity.end(), {i.x, i.y, i.z});
    bool ok = WriteF64(dir / "reflectance.f64", reflectance) && WriteF64(dir / "g.f64", DenseRows(set, set.g, 0.0)) &&
              WriteF64(dir / "h.f64", DenseRows(set, set.h, 0.0)) && WriteF64(dir / "intensity.f64", intensity);
    if (!set.falloff.empty()) {
      ok = ok && WriteF64(dir / "falloff.f64", DenseRows(set, set.falloff, 1.0));
    }
    if (!ok) {
      std::fprintf(stderr, "fit_peer: %s: cannot write the arrays\n", dir.c_str());
      return 4;
    }
    const Timed lm = TimeFit(p, Solver::kLevenbergMarquardt, repeats);
    const Timed powell = TimeFit(p, Solver::kPowell, repeats);
    std::fprintf(stderr, "fit_peer: %-14s %7zu samples  LM %8.4f s  Powell %8.4f s\n", p.name.c_str(), set.size(),
                 lm.median, powell.median);
    std::vector<std::string> truth;
    for (int c = 0; c < 3; ++c) {
      truth.push_back(absl::StrCat("[", Num(p.truth[c].kd), ", ", Num(p.truth[c].ks), ", ", Num(p.truth[c].ke), "]"));
    }
    entries.push_back(absl::StrCat(
        "    {\"name\": \"", p.name, "\", \"description\": \"", p.description, "\", \"dir\": \"", p.name,
        "\", \"samples\": ", set.size(), ", \"lights\": ", set.num_lights(), ", \"mask\": ", p.mask.Word(0),
        ", \"falloff\": ", set.falloff.empty() ? "false" : "true", ", \"truth\": [", absl::StrJoin(truth, ", "),
        "],\n     \"ours\": {\"lm\": ", SolverJson(lm), ",\n              \"powell\": ", SolverJson(powell),
        "},\n     \"ceres_lm_diagnostics\": ", CeresDiagnosticsJson(p, true),
        ",\n     \"ceres_lm_no_line_search_diagnostics\": ", CeresDiagnosticsJson(p, false), "}"));
  }
  const std::string options_json = absl::StrCat(
      "{\"max_iterations\": ", defaults.max_iterations, ", \"function_tolerance\": ", Num(defaults.function_tolerance),
      ", \"parameter_tolerance\": 1e-10, \"kd_max\": ", Num(defaults.kd_max), ", \"ks_max\": ", Num(defaults.ks_max),
      ", \"ke_min\": ", Num(defaults.ke_min), ", \"ke_max\": ", Num(defaults.ke_max), ", \"initial\": [",
      Num(defaults.initial.kd), ", ", Num(defaults.initial.ks), ", ", Num(defaults.initial.ke),
      "], \"initialise_kd_from_data\": ", defaults.initialise_kd_from_data ? "true" : "false",
      ", \"min_cosine\": ", Num(defaults.min_cosine), ", \"min_highlight_samples\": ", defaults.min_highlight_samples,
      ", \"highlight_cosine\": ", Num(defaults.highlight_cosine), ", \"ceres_block_size\": 1024, \"threads\": 1}");
  const std::string manifest =
      absl::StrCat("{\"format\": \"mvbrdf.fit_peer.v1\", \"repeats\": ", repeats, ",\n  \"options\": ", options_json,
                   ",\n  \"problems\": [\n", absl::StrJoin(entries, ",\n"), "\n  ]}\n");
  std::ofstream out(std::filesystem::path(out_dir) / "manifest.json");
  out << manifest;
  if (!out) {
    std::fprintf(stderr, "fit_peer: cannot write %s/manifest.json\n", out_dir.c_str());
    return 4;
  }
  return 0;
}

}  // namespace
}  // namespace mvbrdf::fit

int main(int argc, char** argv) { return mvbrdf::fit::Main(argc, argv); }
