// Per configuration (thesis Fig. 6.2): FitPhong on all samples with the
// caller's options (Levenberg-Marquardt by default), then SolveDiffuse with
// that fit's ks/ke and no fallback kd (unlit triangles get kd = 0 and keep
// their error, which is what penalises a configuration that leaves them dark).
#include "core/fit/light_sweep.h"

#include <algorithm>
#include <cstdint>
#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace mvbrdf::fit {
namespace {

// E_a values closer than this (relative) are a tie.
constexpr double kTieTolerance = 1e-9;

bool NearlyEqual(double a, double b) {
  return std::fabs(a - b) <= kTieTolerance * std::max(std::fabs(a), std::fabs(b));
}

// Triangles with at least one finite sample lit by a light of the mask.
uint32_t CountLitTriangles(const samples::SampleSet& set, const samples::LightSelection& mask, size_t num_triangles) {
  std::vector<uint8_t> lit(num_triangles, 0);
  for (size_t i = 0; i < set.size(); ++i) {
    const uint32_t t = set.element[i];
    if (t >= num_triangles || lit[t]) continue;
    for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) {
      if (mask.Selects(set.frame[i], set.light[j]) && std::isfinite(set.g[j]) && set.g[j] > 0.0f) {
        lit[t] = 1;
        break;
      }
    }
  }
  return static_cast<uint32_t>(std::count(lit.begin(), lit.end(), uint8_t{1}));
}

// E_a (Eq. 6.7) over every finite Sample: mean over Samples and channels.
// Summed in fixed chunks of Samples, then the chunks in order, so the value
// does not depend on how many threads computed the chunks.
double MeanSquaredError(const samples::SampleSet& set, const samples::LightSelection& mask, const PhongRgb& params,
                        int threads) {
  constexpr size_t kChunk = size_t{1} << 16;
  const size_t chunks = (set.size() + kChunk - 1) / kChunk;
  std::vector<double> sums(chunks, 0.0);
  std::vector<size_t> counts(chunks, 0);
  std::atomic<size_t> next{0};
  const auto work = [&]() {
    for (size_t chunk = next++; chunk < chunks; chunk = next++) {
      const size_t end = std::min(set.size(), (chunk + 1) * kChunk);
      double sum = 0.0;  // in registers: no writes to lines other threads write
      size_t count = 0;
      for (size_t i = chunk * kChunk; i < end; ++i) {
        double sq = 0.0;
        for (int c = 0; c < 3; ++c) {
          const double d = set.reflectance[i][c] - EvaluateSample(set, i, mask, params[c], c);
          sq += d * d;
        }
        if (!std::isfinite(sq)) continue;
        sum += sq;
        ++count;
      }
      sums[chunk] = sum;
      counts[chunk] = count;
    }
  };
  const size_t workers = std::min(static_cast<size_t>(std::max(threads, 1)), std::max<size_t>(chunks, 1));
  if (workers <= 1) {
    work();
  } else {
    std::vector<std::thread> pool;
    for (size_t w = 0; w < workers; ++w) pool.emplace_back(work);
    for (std::thread& t : pool) t.join();
  }
  double sum = 0.0;
  size_t n = 0;
  for (size_t chunk = 0; chunk < chunks; ++chunk) {
    sum += sums[chunk];
    n += counts[chunk];
  }
  return n > 0 ? sum / (3.0 * static_cast<double>(n)) : 0.0;
}

absl::Status EvaluateConfiguration(const samples::SampleSet& set, size_t num_triangles,
                                   const PhongFitOptions& fit_options, const DiffuseOptions& diffuse_options,
                                   size_t max_fit_samples, int threads, const std::vector<uint8_t>& own_frames,
                                   SweepRow* row) {
  const auto start = std::chrono::steady_clock::now();
  const samples::LightSelection selection(row->mask, own_frames);
  std::vector<uint32_t> subsample;
  if (max_fit_samples > 0 && set.size() > max_fit_samples) {
    // A hashed, not strided, choice: Samples come ordered by (frame, camera,
    // triangle), and every n-th one could alias with that order and keep
    // only some triangles.
    const uint64_t keep = static_cast<uint64_t>(max_fit_samples) * (uint64_t{1} << 32) / set.size();
    for (size_t i = 0; i < set.size(); ++i) {
      uint64_t x = static_cast<uint64_t>(i) * 0x9e3779b97f4a7c15ULL;
      x ^= x >> 29;
      x *= 0xbf58476d1ce4e5b9ULL;
      x ^= x >> 32;
      if ((x & 0xffffffffULL) < keep) subsample.push_back(static_cast<uint32_t>(i));
    }
  }
  absl::StatusOr<PhongFitResult> fit = FitPhong(set, subsample, selection, fit_options);
  if (!fit.ok()) return fit.status();
  row->fit = *std::move(fit);
  row->e_a = subsample.empty() ? row->fit.mse : MeanSquaredError(set, selection, row->fit.params, threads);
  const DiffuseSolution diffuse =
      SolveDiffuse(set, selection, row->fit.params, num_triangles, diffuse_options, threads);
  row->e_d = diffuse.mean_element_mse;
  row->triangle_kd_scale = diffuse.robust_scale;
  row->triangle_kd_outliers = diffuse.outlier_fraction;
  row->lit_triangles = CountLitTriangles(set, selection, num_triangles);
  row->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<SweepResult> SweepConfigurations(const samples::SampleSet& set, size_t num_triangles,
                                                const std::vector<LightConfiguration>& configurations,
                                                const PhongFitOptions& fit_options,
                                                const DiffuseOptions& diffuse_options, int threads,
                                                size_t max_fit_samples, const std::vector<uint8_t>& own_frames) {
  SweepResult result;
  result.rows.resize(configurations.size());
  for (size_t i = 0; i < configurations.size(); ++i) {
    SweepRow& row = result.rows[i];
    row.name = configurations[i].name;
    row.lights = configurations[i].lights;
    absl::StatusOr<samples::LightMask> mask = set.MaskOf(configurations[i].lights);
    if (!mask.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("configurations[", i, "] (", configurations[i].name, "): ", mask.status().message()));
    }
    row.mask = *mask;
  }

  // Each configuration is independent and deterministic; workers take the
  // next one from a shared counter, so the rows do not depend on `threads`.
  // Threads left over (fewer configurations than threads, e.g. the service's
  // one-configuration sweep tasks) work inside each configuration.
  const size_t workers = std::min(static_cast<size_t>(std::max(threads, 1)), configurations.size());
  const int inner_threads = std::max(1, threads / static_cast<int>(std::max<size_t>(workers, 1)));
  std::vector<absl::Status> statuses(configurations.size());
  std::atomic<size_t> next{0};
  auto work = [&]() {
    for (size_t i = next++; i < configurations.size(); i = next++) {
      statuses[i] = EvaluateConfiguration(set, num_triangles, fit_options, diffuse_options, max_fit_samples,
                                          inner_threads, own_frames, &result.rows[i]);
    }
  };
  if (workers <= 1) {
    work();
  } else {
    std::vector<std::thread> pool;
    for (size_t w = 0; w < workers; ++w) pool.emplace_back(work);
    for (std::thread& t : pool) t.join();
  }
  for (size_t i = 0; i < statuses.size(); ++i) {
    if (!statuses[i].ok()) {
      return absl::Status(statuses[i].code(), absl::StrCat("configurations[", i, "] (", configurations[i].name,
                                                           "): ", statuses[i].message()));
    }
  }

  // The stated rule: lowest E_d; E_a breaks ties.
  for (size_t i = 0; i < result.rows.size(); ++i) {
    if (result.best < 0) {
      result.best = static_cast<int>(i);
      continue;
    }
    const SweepRow& row = result.rows[i];
    const SweepRow& best = result.rows[result.best];
    if (PreferConfiguration(row.e_d, row.e_a, best.e_d, best.e_a)) result.best = static_cast<int>(i);
  }
  return result;
}

bool PreferConfiguration(double e_d, double e_a, double best_e_d, double best_e_a) {
  return NearlyEqual(e_d, best_e_d) ? e_a < best_e_a && !NearlyEqual(e_a, best_e_a) : e_d < best_e_d;
}

}  // namespace mvbrdf::fit
