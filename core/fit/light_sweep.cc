// Per configuration (thesis Fig. 6.2): FitPhong on all samples with the
// caller's options (Levenberg-Marquardt by default), then SolveDiffuse with
// that fit's ks/ke and no fallback kd (unlit triangles get kd = 0 and keep
// their error, which is what penalises a configuration that leaves them dark).
// Then the held-out error (issue #14, HeldOutError below).
#include "core/fit/light_sweep.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <thread>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/vector_exp.h"
#include "core/fit/phong_terms.h"

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
        const glm::dvec3 f = EvaluateSampleRgb(set, i, mask, params);
        double sq = 0.0;
        for (int c = 0; c < 3; ++c) {
          const double d = set.reflectance[i][c] - f[c];
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

// --- The held-out error (light_sweep.h) --------------------------------------

// The search over ke of the joint fit: a coarse log grid over [ke_min,
// ke_max], then halved steps either side of the best; 9 + 6 passes over the
// highlighted Samples, and one for the held-out errors.
constexpr int kKeGrid = 9;
constexpr int kKeRefinements = 3;

// Per Sample, its fold; per term, ln h' (NaN where the term has no
// highlight): shared by every configuration.
struct HeldOutInput {
  std::vector<uint8_t> fold;
  int num_folds = 0;
  std::vector<float> log_h;
};

// The frames present in the Samples, in order, split into kHeldOutFolds
// contiguous blocks of (nearly) equal frame counts; with one frame, the
// cameras in the same way.
HeldOutInput PrepareHeldOut(const samples::SampleSet& set) {
  HeldOutInput in;
  in.fold.assign(set.size(), 0);
  std::vector<uint8_t> frame_seen(65536, 0), camera_seen(256, 0);
  for (size_t i = 0; i < set.size(); ++i) {
    frame_seen[set.frame[i]] = 1;
    camera_seen[set.camera[i]] = 1;
  }
  const bool by_frame = std::count(frame_seen.begin(), frame_seen.end(), uint8_t{1}) > 1;
  const std::vector<uint8_t>& seen = by_frame ? frame_seen : camera_seen;
  const int distinct = static_cast<int>(std::count(seen.begin(), seen.end(), uint8_t{1}));
  in.num_folds = std::max(1, std::min(kHeldOutFolds, distinct));
  std::vector<uint8_t> fold_of(seen.size(), 0);
  int rank = 0;
  for (size_t v = 0; v < seen.size(); ++v) {
    if (!seen[v]) continue;
    fold_of[v] = static_cast<uint8_t>(static_cast<int64_t>(rank) * in.num_folds / distinct);
    ++rank;
  }
  for (size_t i = 0; i < set.size(); ++i) in.fold[i] = fold_of[by_frame ? set.frame[i] : set.camera[i]];
  in.log_h.assign(set.num_terms(), std::numeric_limits<float>::quiet_NaN());
  for (size_t j = 0; j < set.num_terms(); ++j) {
    const double h = internal::ClampedHighlight(internal::ClampedCosine(set.g[j]), set.h[j]);
    if (h > 0.0) in.log_h[j] = static_cast<float>(std::log(h));
  }
  return in;
}

// Sums over Samples: G^2, r G, r^2 (per channel) and the count.
struct DiffuseSums {
  glm::dvec3 gg{0.0}, rg{0.0}, rr{0.0};
  uint32_t count = 0;
  void Add(const DiffuseSums& o) {
    gg += o.gg;
    rg += o.rg;
    rr += o.rr;
    count += o.count;
  }
};
// With the specular part s = sum_k I_k a_k h_k^ke: s^2, r s, s G.
struct SpecularSums {
  glm::dvec3 ss{0.0}, rs{0.0}, sg{0.0};
  void Add(const SpecularSums& o) {
    ss += o.ss;
    rs += o.rs;
    sg += o.sg;
  }
};

// Calls work(part) for parts [0, parts), each on its own thread.
template <typename F>
void Parallel(uint32_t parts, F&& work) {
  if (parts <= 1) {
    work(0u);
    return;
  }
  std::vector<std::thread> pool;
  for (uint32_t t = 0; t < parts; ++t) pool.emplace_back(work, t);
  for (std::thread& t : pool) t.join();
}

double HeldOutError(const samples::SampleSet& set, const samples::LightSelection& mask, const HeldOutInput& in,
                    size_t num_triangles, const PhongFitOptions& fit_options, const DiffuseOptions& options,
                    int threads) {
  if (in.num_folds < 2) return 0.0;
  const size_t F = static_cast<size_t>(in.num_folds);
  const size_t num_lights = static_cast<size_t>(set.num_lights());
  std::vector<uint8_t> in_mask(num_lights, 0);
  for (size_t k = 0; k < num_lights; ++k) in_mask[k] = mask.config.Test(k) ? 1 : 0;

  // The configuration's Samples: the diffuse sums per (triangle, fold), and
  // the Samples with a highlight with their highlight terms (weight I a,
  // ln h) for the passes over ke.
  std::vector<DiffuseSums> diffuse(num_triangles * F);
  struct Highlighted {
    uint32_t sample;
    uint32_t terms_end;  // its terms: [the previous one's terms_end, terms_end)
    glm::vec3 illumination;
  };
  std::vector<Highlighted> highlighted;
  std::vector<glm::vec3> weight;
  std::vector<float> log_h;
  // Room for every Sample and term: no copies as they grow (pages never
  // written are never touched).
  highlighted.reserve(set.size());
  weight.reserve(set.num_terms());
  log_h.reserve(set.num_terms());
  size_t max_terms = 0;  // of one Sample
  for (size_t i = 0; i < set.size(); ++i) {
    const uint32_t t = set.element[i];
    const glm::vec3& r = set.reflectance[i];
    if (t >= num_triangles || !std::isfinite(r.x) || !std::isfinite(r.y) || !std::isfinite(r.z)) continue;
    const bool own = mask.Own(set.frame[i]);
    glm::dvec3 illumination(0.0);
    bool finite = true;
    const size_t first_term = log_h.size();
    for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) {
      const size_t k = set.light[j];
      if (!own && !in_mask[k]) continue;
      if (!std::isfinite(set.g[j]) || !std::isfinite(set.h[j])) {
        finite = false;
        break;
      }
      illumination += glm::dvec3(set.light_intensity[k]) * internal::ClampedCosine(set.g[j]);
      if (!std::isnan(in.log_h[j])) {
        weight.push_back(set.light_intensity[k] * set.TermFalloff(j));
        log_h.push_back(in.log_h[j]);
      }
    }
    if (!finite) {
      weight.resize(first_term);
      log_h.resize(first_term);
      continue;
    }
    DiffuseSums& d = diffuse[static_cast<size_t>(t) * F + in.fold[i]];
    const glm::dvec3 rd(r);
    d.gg += illumination * illumination;
    d.rg += rd * illumination;
    d.rr += rd * rd;
    ++d.count;
    if (log_h.size() > first_term) {
      highlighted.push_back({static_cast<uint32_t>(i), static_cast<uint32_t>(log_h.size()), glm::vec3(illumination)});
      max_terms = std::max(max_terms, log_h.size() - first_term);
    }
  }
  // The data's scale, as DiffuseAccumulator::ScaleOf.
  glm::dvec3 gg_all(0.0), rr_all(0.0), g2(1.0), albedo(1.0);
  double n_all = 0.0;
  for (const DiffuseSums& d : diffuse) {
    gg_all += d.gg;
    rr_all += d.rr;
    n_all += d.count;
  }
  for (int c = 0; c < 3; ++c) {
    const double m = n_all > 0.0 ? gg_all[c] / n_all : 0.0;
    if (m > 0.0 && std::isfinite(m)) g2[c] = m;
    const double a = gg_all[c] > 0.0 ? std::sqrt(rr_all[c] / gg_all[c]) : 0.0;
    if (a > 0.0 && std::isfinite(a)) albedo[c] = a;
  }
  const auto lit = [&](double gg, int c) { return gg > 0.0 && gg >= options.min_illumination * g2[c]; };

  // One pass at ke (per channel): the specular sums per (triangle, fold).
  // Threads take contiguous blocks of triangles, each triangle's Samples in
  // their order: the sums do not depend on `threads`.
  std::vector<SpecularSums> specular(num_triangles * F);
  const uint32_t parts = static_cast<uint32_t>(std::clamp(threads, 1, 64));
  const size_t block = (num_triangles + parts - 1) / parts;
  // The exponentials are taken for a run of a part's Samples at once
  // (base::ExpAffine, vectorised, within 2 ulp of std::exp): at least this
  // many terms' worth of room, and one Sample's terms always fit.
  const size_t run_room = std::max<size_t>(1024, max_terms);
  const auto pass = [&](const glm::dvec3& ke) {
    std::fill(specular.begin(), specular.end(), SpecularSums());
    const bool same = ke.x == ke.y && ke.x == ke.z;
    const int rows = same ? 1 : 3;
    Parallel(parts, [&](uint32_t part) {
      const size_t first = part * block, last = std::min(num_triangles, first + block);
      std::vector<double> x(run_room), exps(3 * run_room);
      struct Member {
        uint32_t sample;      // index into `highlighted`
        uint32_t terms_begin;
      };
      std::vector<Member> run;
      size_t next = 0, next_terms = 0;  // the next highlighted Sample and its first term
      while (next < highlighted.size()) {
        // A run of this part's Samples: their terms' ln h, contiguous.
        run.clear();
        size_t n = 0;
        for (; next < highlighted.size(); ++next) {
          const Highlighted& e = highlighted[next];
          const uint32_t t = set.element[e.sample];
          if (t >= first && t < last) {
            if (n + (e.terms_end - next_terms) > run_room) break;
            run.push_back({static_cast<uint32_t>(next), static_cast<uint32_t>(next_terms)});
            for (size_t q = next_terms; q < e.terms_end; ++q) x[n++] = log_h[q];
          }
          next_terms = e.terms_end;
        }
        for (int c = 0; c < rows; ++c) base::ExpAffine(n, ke[c], x.data(), nullptr, exps.data() + c * run_room);
        size_t m = 0;
        for (const Member& member : run) {
          const Highlighted& e = highlighted[member.sample];
          glm::dvec3 s(0.0);
          for (size_t q = member.terms_begin; q < e.terms_end; ++q, ++m) {
            // h^ke below e^-50 (2e-22) adds nothing a double can hold beside G.
            const glm::dvec3 w(weight[q]);
            if (same) {
              if (ke.x * log_h[q] > -50.0) s += w * exps[m];
            } else {
              for (int c = 0; c < 3; ++c) {
                if (ke[c] * log_h[q] > -50.0) s[c] += w[c] * exps[c * run_room + m];
              }
            }
          }
          SpecularSums& o = specular[static_cast<size_t>(set.element[e.sample]) * F + in.fold[e.sample]];
          const glm::dvec3 rd(set.reflectance[e.sample]), g(e.illumination);
          o.ss += s * s;
          o.rs += rd * s;
          o.sg += s * g;
        }
      }
    });
  };

  // The joint fit on every Sample (variable projection): each triangle's kd
  // eliminated in closed form, ks in closed form for a given ke, ke searched.
  // Per channel, summed over triangles: SSE(ks) = A - 2 ks B + ks^2 C.
  const auto fit_at = [&](const glm::dvec3& ke, glm::dvec3* ks, glm::dvec3* cost) {
    pass(ke);
    glm::dvec3 A(0.0), B(0.0), C(0.0);
    for (size_t t = 0; t < num_triangles; ++t) {
      DiffuseSums d;
      SpecularSums s;
      for (size_t f = 0; f < F; ++f) {
        d.Add(diffuse[t * F + f]);
        s.Add(specular[t * F + f]);
      }
      if (d.count == 0) continue;
      for (int c = 0; c < 3; ++c) {
        if (lit(d.gg[c], c)) {
          A[c] += d.rr[c] - d.rg[c] * d.rg[c] / d.gg[c];
          B[c] += s.rs[c] - d.rg[c] * s.sg[c] / d.gg[c];
          C[c] += s.ss[c] - s.sg[c] * s.sg[c] / d.gg[c];
        } else {
          A[c] += d.rr[c];
          B[c] += s.rs[c];
          C[c] += s.ss[c];
        }
      }
    }
    for (int c = 0; c < 3; ++c) {
      double k = C[c] > 0.0 ? std::clamp(B[c] / C[c], 0.0, fit_options.ks_max * albedo[c]) : 0.0;
      if (!std::isfinite(k)) k = 0.0;
      (*ks)[c] = k;
      (*cost)[c] = A[c] - 2.0 * k * B[c] + k * k * C[c];
    }
  };
  const double log_min = std::log(std::max(fit_options.ke_min, 1e-3));
  const double log_max = std::max(std::log(std::max(fit_options.ke_max, 1e-3)), log_min);
  const double step = (log_max - log_min) / (kKeGrid - 1);
  glm::dvec3 best_log(log_min), best_ks(0.0), best_cost(std::numeric_limits<double>::infinity());
  const auto consider = [&](const glm::dvec3& log_ke) {
    glm::dvec3 ks, cost;
    fit_at(glm::exp(log_ke), &ks, &cost);
    for (int c = 0; c < 3; ++c) {
      if (cost[c] < best_cost[c]) {
        best_cost[c] = cost[c];
        best_log[c] = log_ke[c];
        best_ks[c] = ks[c];
      }
    }
  };
  for (int g = 0; g < kKeGrid; ++g) consider(glm::dvec3(log_min + g * step));
  double h = step;
  for (int level = 0; level < kKeRefinements; ++level) {
    h /= 2.0;
    const glm::dvec3 centre = best_log;
    for (double sign : {1.0, -1.0}) consider(glm::clamp(centre + sign * h, glm::dvec3(log_min), glm::dvec3(log_max)));
  }

  // Held out: for each fold, each triangle's kd from the other folds (with the
  // joint fit's ks, ke) and its squared error on the fold; per triangle the
  // mean over its held-out Samples (folds whose complement saw it) and
  // channels.
  pass(glm::exp(best_log));
  std::vector<double> per_triangle;
  for (size_t t = 0; t < num_triangles; ++t) {
    double sse = 0.0;
    uint64_t held_out = 0;
    for (size_t f = 0; f < F; ++f) {
      const DiffuseSums& test = diffuse[t * F + f];
      const SpecularSums& test_s = specular[t * F + f];
      DiffuseSums train;
      SpecularSums train_s;
      for (size_t o = 0; o < F; ++o) {
        if (o == f) continue;
        train.Add(diffuse[t * F + o]);
        train_s.Add(specular[t * F + o]);
      }
      if (test.count == 0 || train.count == 0) continue;
      for (int c = 0; c < 3; ++c) {
        const double ks = best_ks[c];
        double kd = 0.0;  // never lit where it was fitted: kd = 0 keeps the error (as E_d)
        if (lit(train.gg[c], c)) {
          kd = std::clamp((train.rg[c] - ks * train_s.sg[c]) / train.gg[c], 0.0, options.kd_max * albedo[c]);
        }
        if (!std::isfinite(kd)) kd = 0.0;
        // sum (r - kd G - ks s)^2 over the fold's Samples.
        sse += std::max(0.0, test.rr[c] + kd * kd * test.gg[c] + ks * ks * test_s.ss[c] - 2.0 * kd * test.rg[c] -
                                 2.0 * ks * test_s.rs[c] + 2.0 * kd * ks * test_s.sg[c]);
      }
      held_out += test.count;
    }
    if (held_out > 0) per_triangle.push_back(sse / (3.0 * static_cast<double>(held_out)));
  }
  if (per_triangle.empty()) return 0.0;
  // The median over triangles.
  const auto middle = per_triangle.begin() + static_cast<std::ptrdiff_t>(per_triangle.size() / 2);
  std::nth_element(per_triangle.begin(), middle, per_triangle.end());
  return *middle;
}

absl::Status EvaluateConfiguration(const samples::SampleSet& set, size_t num_triangles,
                                   const PhongFitOptions& fit_options, const DiffuseOptions& diffuse_options,
                                   size_t max_fit_samples, int threads, const std::vector<uint8_t>& own_frames,
                                   const HeldOutInput& held_out, SweepRow* row) {
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
  // The fit's channels on threads of their own only when this configuration
  // has threads to spare: a one-thread sweep (each of the service's sweep
  // tasks) stays on its one core, as its worker's --threads promises.
  PhongFitOptions options = fit_options;
  if (threads <= 1) options.parallel_channels = false;
  absl::StatusOr<PhongFitResult> fit = FitPhong(set, subsample, selection, options);
  if (!fit.ok()) return fit.status();
  row->fit = *std::move(fit);
  row->e_a = subsample.empty() ? row->fit.mse : MeanSquaredError(set, selection, row->fit.params, threads);
  const DiffuseSolution diffuse =
      SolveDiffuse(set, selection, row->fit.params, num_triangles, diffuse_options, threads);
  row->e_d = diffuse.mean_element_mse;
  row->e_held_out = HeldOutError(set, selection, held_out, num_triangles, fit_options, diffuse_options, threads);
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
                                                size_t max_fit_samples, const std::vector<uint8_t>& own_frames,
                                                SweepCriterion criterion) {
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
  const HeldOutInput held_out = PrepareHeldOut(set);
  std::vector<absl::Status> statuses(configurations.size());
  std::atomic<size_t> next{0};
  auto work = [&]() {
    for (size_t i = next++; i < configurations.size(); i = next++) {
      statuses[i] = EvaluateConfiguration(set, num_triangles, fit_options, diffuse_options, max_fit_samples,
                                          inner_threads, own_frames, held_out, &result.rows[i]);
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

  // The stated rule (PreferConfiguration).
  for (size_t i = 0; i < result.rows.size(); ++i) {
    if (result.best < 0) {
      result.best = static_cast<int>(i);
      continue;
    }
    const SweepRow& row = result.rows[i];
    const SweepRow& best = result.rows[result.best];
    if (PreferConfiguration(criterion, {row.e_a, row.e_d, row.e_held_out}, {best.e_a, best.e_d, best.e_held_out})) {
      result.best = static_cast<int>(i);
    }
  }
  return result;
}

bool PreferConfiguration(double e_d, double e_a, double best_e_d, double best_e_a) {
  return NearlyEqual(e_d, best_e_d) ? e_a < best_e_a && !NearlyEqual(e_a, best_e_a) : e_d < best_e_d;
}

bool PreferConfiguration(SweepCriterion criterion, const ConfigurationErrors& row, const ConfigurationErrors& best) {
  if (criterion == SweepCriterion::kHeldOut && !NearlyEqual(row.e_held_out, best.e_held_out)) {
    return row.e_held_out < best.e_held_out;
  }
  return PreferConfiguration(row.e_d, row.e_a, best.e_d, best.e_a);
}

}  // namespace mvbrdf::fit
