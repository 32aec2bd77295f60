// Weighted Lloyd k-means in linear RGB (thesis §6.2.1).
//
// Iteration: assign every point to the nearest allowed centre (squared
// Euclidean distance in linear RGB; ties to the lowest index), then move
// every centre to the weighted mean of its points. Stop after an iteration in
// which fewer than min_change_fraction of the points (or none) changed
// cluster, or after max_iterations; the reported assignment, sizes and inertia
// are then recomputed against the final centres.
//
// Empty clusters (no point, or zero total weight) keep their previous centre:
// a seed that no texel resembles stays where the scene put it rather than
// jumping to an arbitrary point, so its name keeps meaning that material.
//
// Automatic k (no seeds): k-means++ seeding (weighted by w D^2) with fixed
// generators seeded from options.random_seed + r gives kAutomaticRestarts
// sequences of centres; the runs for k start from the first k of each, and
// the one with the lowest inertia is I(k) (one sequence alone lands in a
// local minimum, two seeds in one blob, a few times in a hundred). Criterion: the largest k in
// 2..max_automatic_k whose cluster removed at least kAutomaticMinGain (40 %)
// of the inertia of k - 1, I(k) <= (1 - 0.4) I(k-1), and whose neighbouring
// clusters are separated by a valley of the data (SeparatedByValleys; issue
// #13: one material stretched along its albedo by shading errors lost 75 %
// of its inertia to a split and came out as 3-4 clusters); 1 when none did.
// Splitting a compact blob removes well under 40 % of its inertia (an
// isotropic Gaussian ~21 %, a uniform box 25 %), and once every blob has its
// cluster that is at most ~25 % / k of the total; separating two blobs whose
// distance is several noise widths removes far more. (The largest such k, not
// the smallest k after which the gain drops: with several symmetric blobs the
// first split can gain little, e.g. 5 blobs at the corners and centre of a
// simplex.) The sweep stops at the first k with zero inertia (no more than k
// distinct points). Inputs of more than kAutomaticSample points choose k on
// a stride subsample of about that many (weights kept), then run Lloyd on all
// points from the subsample's centres.

//
// Degenerate inputs: no points, a total weight of zero, a non-finite point,
// weight or seed, a negative weight, a segment index out of range or a segment
// whose allowed list is empty or names an unknown cluster are INVALID_ARGUMENT
// naming the offending index.
//
// Deterministic: single-threaded, fixed iteration order and generator.
#include "core/cluster/kmeans.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace mvbrdf::cluster {
namespace {

constexpr double kAutomaticMinGain = 0.4;
constexpr size_t kAutomaticSample = 16384;
constexpr int kAutomaticRestarts = 4;

bool Finite(const glm::vec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

float Distance2(const glm::vec3& a, const glm::vec3& b) {
  const glm::vec3 d = a - b;
  return glm::dot(d, d);
}

// Per point: the clusters it may join (a shared list per segment).
struct Allowed {
  std::vector<std::vector<uint32_t>> lists;  // per segment, plus "all" last
  const std::vector<uint32_t>& For(const KMeansInput& input, size_t i) const {
    return input.segment.empty() ? lists.back() : lists[input.segment[i]];
  }
};

float Weight(const KMeansInput& input, size_t i) { return input.weights.empty() ? 1.0f : input.weights[i]; }

// Nearest allowed centre; ties to the lowest index (lists are sorted).
uint32_t Nearest(const glm::vec3& p, const std::vector<glm::vec3>& centres, const std::vector<uint32_t>& allowed,
                 float* distance2) {
  uint32_t best = allowed[0];
  float best_d = Distance2(p, centres[best]);
  for (size_t j = 1; j < allowed.size(); ++j) {
    const float d = Distance2(p, centres[allowed[j]]);
    if (d < best_d) {
      best_d = d;
      best = allowed[j];
    }
  }
  *distance2 = best_d;
  return best;
}

// Lloyd from `centres` (modified in place); fills the result but not names.
KMeansResult Lloyd(const KMeansInput& input, const Allowed& allowed, std::vector<glm::vec3> centres,
                   const KMeansOptions& options) {
  const size_t n = input.points.size();
  const size_t k = centres.size();
  KMeansResult result;
  std::vector<uint32_t> assignment(n, std::numeric_limits<uint32_t>::max());
  std::vector<glm::dvec3> sums(k);
  std::vector<double> totals(k);
  size_t changed = n;
  int iterations = 0;
  while (iterations < options.max_iterations) {
    changed = 0;
    std::fill(sums.begin(), sums.end(), glm::dvec3(0.0));
    std::fill(totals.begin(), totals.end(), 0.0);
    for (size_t i = 0; i < n; ++i) {
      float d;
      const uint32_t c = Nearest(input.points[i], centres, allowed.For(input, i), &d);
      changed += c != assignment[i];
      assignment[i] = c;
      const double w = Weight(input, i);
      sums[c] += w * glm::dvec3(input.points[i]);
      totals[c] += w;
    }
    for (size_t c = 0; c < k; ++c) {
      if (totals[c] > 0.0) centres[c] = glm::vec3(sums[c] / totals[c]);  // else: keeps its centre
    }
    ++iterations;
    if (changed == 0 || static_cast<double>(changed) < options.min_change_fraction * static_cast<double>(n)) break;
  }
  // The final assignment against the final centres.
  result.sizes.assign(k, 0);
  result.inertia = 0.0;
  for (size_t i = 0; i < n; ++i) {
    float d;
    assignment[i] = Nearest(input.points[i], centres, allowed.For(input, i), &d);
    ++result.sizes[assignment[i]];
    result.inertia += static_cast<double>(Weight(input, i)) * d;
  }
  result.centres = std::move(centres);
  result.assignment = std::move(assignment);
  result.iterations = iterations;
  return result;
}

// A uniform double in [0, 1) from 53 bits of the generator (the standard
// distributions are implementation-defined; this is the same everywhere).
double Uniform(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

// Whether every two neighbouring clusters of `run` (the midpoint of their
// centres nearer to them than to any other centre) have a valley between
// them: projected on the line through their centres (t = 0 at one, 1 at the
// other), the weight of their points in the middle band |t - 0.5| < 0.1 is
// below kValleyRatio of the smaller of the weights in the bands |t| < 0.1
// and |t - 1| < 0.1 of the same width. A blob split in two (Gaussian: ratio
// ~1.4, uniform or stretched along a line by shading: ~1) has no valley; two
// equal Gaussian blobs 5 noise widths apart have 0.09, 4 widths 0.27. Only
// ratios of distances and weights: free of units. (A small material beside
// a large noisy one needs a deeper valley than two of equal size.)
constexpr double kValleyRatio = 0.3;

bool SeparatedByValleys(const KMeansInput& input, const KMeansResult& run) {
  const size_t k = run.centres.size();
  for (size_t i = 0; i < k; ++i) {
    for (size_t j = i + 1; j < k; ++j) {
      const glm::vec3 a = run.centres[i], b = run.centres[j];
      const glm::vec3 mid = 0.5f * (a + b);
      const float half = Distance2(mid, a);
      if (!(half > 0.0f)) return false;
      bool neighbours = true;
      for (size_t c = 0; c < k && neighbours; ++c) {
        if (c != i && c != j && Distance2(mid, run.centres[c]) < half) neighbours = false;
      }
      if (!neighbours) continue;
      const glm::vec3 axis = b - a;
      const float length2 = glm::dot(axis, axis);
      double near_a = 0.0, near_b = 0.0, middle = 0.0;
      for (size_t p = 0; p < input.points.size(); ++p) {
        if (run.assignment[p] != i && run.assignment[p] != j) continue;
        const double t = glm::dot(input.points[p] - a, axis) / length2;
        const double w = Weight(input, p);
        if (std::fabs(t) < 0.1) near_a += w;
        if (std::fabs(t - 1.0) < 0.1) near_b += w;
        if (std::fabs(t - 0.5) < 0.1) middle += w;
      }
      if (!(middle < kValleyRatio * std::min(near_a, near_b))) return false;
    }
  }
  return true;
}

// Weighted k-means++: the first centre with probability proportional to w,
// each next one to w D^2. Stops early when every point coincides with a centre.
std::vector<glm::vec3> KMeansPlusPlus(const KMeansInput& input, int max_k, uint32_t seed) {
  const size_t n = input.points.size();
  std::mt19937_64 rng(seed);
  std::vector<double> d2(n, 1.0);  // 1 for the first pick: proportional to w
  std::vector<glm::vec3> centres;
  while (static_cast<int>(centres.size()) < max_k) {
    double total = 0.0;
    for (size_t i = 0; i < n; ++i) total += Weight(input, i) * d2[i];
    if (!(total > 0.0)) break;
    const double target = Uniform(rng) * total;
    double running = 0.0;
    size_t pick = n;
    for (size_t i = 0; i < n; ++i) {
      const double p = Weight(input, i) * d2[i];
      if (p <= 0.0) continue;
      pick = i;  // the last point with positive probability catches rounding at the end
      running += p;
      if (running > target) break;
    }
    centres.push_back(input.points[pick]);
    const bool first = centres.size() == 1;
    for (size_t i = 0; i < n; ++i) {
      const double d = Distance2(input.points[i], centres.back());
      d2[i] = first ? d : std::min(d2[i], d);
    }
  }
  return centres;
}

absl::Status Validate(const KMeansInput& input, const KMeansOptions& options, size_t num_seeds) {
  const size_t n = input.points.size();
  if (options.max_iterations < 1) {
    return absl::InvalidArgumentError(absl::StrCat("k-means: max_iterations must be >= 1, got ", options.max_iterations));
  }
  if (!(options.min_change_fraction >= 0.0)) {
    return absl::InvalidArgumentError("k-means: min_change_fraction must be >= 0");
  }
  if (num_seeds == 0 && options.max_automatic_k < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("k-means: max_automatic_k must be >= 1, got ", options.max_automatic_k));
  }
  if (!options.seed_names.empty() && options.seed_names.size() != num_seeds) {
    return absl::InvalidArgumentError(absl::StrCat("k-means: ", options.seed_names.size(), " seed_names for ",
                                                   num_seeds, " seeds"));
  }
  for (size_t s = 0; s < num_seeds; ++s) {
    if (!Finite(options.seeds[s])) return absl::InvalidArgumentError(absl::StrCat("k-means: seeds[", s, "] is not finite"));
  }
  if (n == 0) return absl::InvalidArgumentError("k-means: no points");
  if (!input.weights.empty() && input.weights.size() != n) {
    return absl::InvalidArgumentError(
        absl::StrCat("k-means: ", input.weights.size(), " weights for ", n, " points (expected one each or none)"));
  }
  double total = 0.0;
  for (size_t i = 0; i < n; ++i) {
    if (!Finite(input.points[i])) {
      return absl::InvalidArgumentError(absl::StrCat("k-means: points[", i, "] is not finite"));
    }
    const float w = Weight(input, i);
    if (!(w >= 0.0f) || !std::isfinite(w)) {
      return absl::InvalidArgumentError(absl::StrCat("k-means: weights[", i, "] must be finite and >= 0, got ", w));
    }
    total += w;
  }
  if (!(total > 0.0)) return absl::InvalidArgumentError("k-means: the weights sum to zero");
  if (input.segment.empty()) return absl::OkStatus();
  if (num_seeds == 0) {
    return absl::InvalidArgumentError("k-means: segment restrictions name seeds, but no seeds were given");
  }
  if (input.segment.size() != n) {
    return absl::InvalidArgumentError(
        absl::StrCat("k-means: ", input.segment.size(), " segment indices for ", n, " points"));
  }
  for (size_t s = 0; s < input.allowed_clusters.size(); ++s) {
    for (uint32_t c : input.allowed_clusters[s]) {
      if (c >= num_seeds) {
        return absl::InvalidArgumentError(absl::StrCat("k-means: allowed_clusters[", s, "] names cluster ", c,
                                                       ", but there are ", num_seeds, " seeds"));
      }
    }
  }
  for (size_t i = 0; i < n; ++i) {
    const uint32_t s = input.segment[i];
    if (s >= input.allowed_clusters.size()) {
      return absl::InvalidArgumentError(absl::StrCat("k-means: segment[", i, "] = ", s, " is out of range (",
                                                     input.allowed_clusters.size(), " segments)"));
    }
    if (input.allowed_clusters[s].empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat("k-means: points[", i, "] lies in segment ", s, ", which allows no cluster"));
    }
  }
  return absl::OkStatus();
}

Allowed MakeAllowed(const KMeansInput& input, size_t k) {
  Allowed allowed;
  if (!input.segment.empty()) {
    for (const std::vector<uint32_t>& list : input.allowed_clusters) {
      std::vector<uint32_t> sorted = list;
      std::sort(sorted.begin(), sorted.end());
      sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
      allowed.lists.push_back(std::move(sorted));
    }
  }
  std::vector<uint32_t> all(k);
  for (size_t c = 0; c < k; ++c) all[c] = static_cast<uint32_t>(c);
  allowed.lists.push_back(std::move(all));
  return allowed;
}

// KMeans, and with automatic k the run at the largest k tried into `largest`
// (when not null; its Lloyd on every point, no names).
absl::StatusOr<KMeansResult> KMeansAndLargest(const KMeansInput& input, const KMeansOptions& options,
                                              KMeansResult* largest) {
  const size_t num_seeds = options.seeds.size();
  if (absl::Status status = Validate(input, options, num_seeds); !status.ok()) return status;

  if (num_seeds > 0) {
    KMeansResult result = Lloyd(input, MakeAllowed(input, num_seeds), options.seeds, options);
    for (size_t c = 0; c < num_seeds; ++c) {
      result.names.push_back(options.seed_names.empty() ? absl::StrCat("cluster ", c) : options.seed_names[c]);
    }
    return result;
  }

  // k on a stride subsample of large inputs.
  const size_t n = input.points.size();
  const size_t stride = (n + kAutomaticSample - 1) / kAutomaticSample;
  KMeansInput sample;
  if (stride > 1) {
    for (size_t i = 0; i < n; i += stride) {
      sample.points.push_back(input.points[i]);
      if (!input.weights.empty()) sample.weights.push_back(input.weights[i]);
    }
    double total = 0.0;
    for (size_t i = 0; i < sample.points.size(); ++i) total += Weight(sample, i);
    if (!(total > 0.0)) sample = input;  // every sampled weight zero: use everything
  }
  const KMeansInput& choose_on = stride > 1 ? sample : input;

  std::vector<std::vector<glm::vec3>> plus_plus;
  size_t max_k = 0;
  for (int r = 0; r < kAutomaticRestarts; ++r) {
    plus_plus.push_back(KMeansPlusPlus(choose_on, options.max_automatic_k, options.random_seed + r));
    max_k = std::max(max_k, plus_plus.back().size());  // the same for every r: the distinct points
  }
  KMeansResult chosen, previous;
  for (size_t k = 1; k <= max_k; ++k) {
    KMeansResult run;
    bool have_run = false;
    for (const std::vector<glm::vec3>& sequence : plus_plus) {
      if (sequence.size() < k) continue;
      KMeansResult attempt = Lloyd(choose_on, MakeAllowed(choose_on, k),
                                   std::vector<glm::vec3>(sequence.begin(), sequence.begin() + k), options);
      if (!have_run || attempt.inertia < run.inertia) run = std::move(attempt);
      have_run = true;
    }
    if (k == 1 || (run.inertia <= (1.0 - kAutomaticMinGain) * previous.inertia && SeparatedByValleys(choose_on, run))) {
      chosen = run;
    }
    if (run.inertia <= 0.0 || k == max_k) {  // every point on a centre, or the last k
      if (largest != nullptr) {
        *largest =
            &choose_on != &input ? Lloyd(input, MakeAllowed(input, run.centres.size()), run.centres, options) : run;
      }
      break;
    }
    previous = std::move(run);
  }
  if (&choose_on != &input) chosen = Lloyd(input, MakeAllowed(input, chosen.centres.size()), chosen.centres, options);
  chosen.automatic_k = true;
  for (size_t c = 0; c < chosen.centres.size(); ++c) chosen.names.push_back(absl::StrCat("cluster ", c));
  return chosen;
}

}  // namespace

absl::StatusOr<KMeansResult> KMeans(const KMeansInput& input, const KMeansOptions& options) {
  return KMeansAndLargest(input, options, nullptr);
}

std::vector<bool> MergeTinyClusters(const KMeansInput& input, KMeansResult* result) {
  const size_t k = result->centres.size();
  std::vector<bool> tiny(k, false);
  const size_t n = result->assignment.size();
  if (k < 2 || n == 0) return tiny;
  const double limit = std::max(static_cast<double>(kMinMaterialPoints), kMinMaterialShare * static_cast<double>(n));
  const size_t largest =
      static_cast<size_t>(std::max_element(result->sizes.begin(), result->sizes.end()) - result->sizes.begin());
  bool any = false;
  for (size_t c = 0; c < k; ++c) {
    tiny[c] = c != largest && result->sizes[c] > 0 && static_cast<double>(result->sizes[c]) < limit;
    any = any || tiny[c];
  }
  if (!any) return tiny;
  std::vector<uint32_t> kept;
  for (size_t c = 0; c < k; ++c) {
    if (!tiny[c]) kept.push_back(static_cast<uint32_t>(c));
  }
  std::vector<bool> received(k, false);
  for (size_t i = 0; i < n; ++i) {
    if (!tiny[result->assignment[i]]) continue;
    float d;
    const uint32_t to = Nearest(input.points[i], result->centres, kept, &d);
    --result->sizes[result->assignment[i]];
    ++result->sizes[to];
    result->assignment[i] = to;
    received[to] = true;
  }
  std::vector<glm::dvec3> sums(k, glm::dvec3(0.0));
  std::vector<double> totals(k, 0.0);
  for (size_t i = 0; i < n; ++i) {
    const double w = Weight(input, i);
    sums[result->assignment[i]] += w * glm::dvec3(input.points[i]);
    totals[result->assignment[i]] += w;
  }
  for (size_t c = 0; c < k; ++c) {
    if (received[c] && totals[c] > 0.0) result->centres[c] = glm::vec3(sums[c] / totals[c]);
  }
  result->inertia = 0.0;
  for (size_t i = 0; i < n; ++i) {
    result->inertia +=
        static_cast<double>(Weight(input, i)) * Distance2(input.points[i], result->centres[result->assignment[i]]);
  }
  return tiny;
}

absl::StatusOr<KMeansResult> KMeansOfMaterials(const KMeansInput& input, const KMeansOptions& options,
                                               std::vector<bool>* tiny) {
  KMeansResult largest;
  absl::StatusOr<KMeansResult> first = KMeansAndLargest(input, options, &largest);
  if (!first.ok()) return first.status();
  tiny->assign(first->centres.size(), false);
  if (!first->automatic_k) return first;
  KMeansResult merged = *first;
  std::vector<bool> first_tiny = MergeTinyClusters(input, &merged);
  const auto none = [](const std::vector<bool>& v) { return std::find(v.begin(), v.end(), true) == v.end(); };
  // The outliers: the first run's tiny clusters or, where it has none, the
  // largest k's: outliers that are not far enough off for a chosen k to
  // isolate them still add to every k's inertia (the 6-frame actor at 128^2:
  // 35 texels with albedo estimates of 3-30 hid two of its three materials).
  const KMeansResult* outliers_from = &*first;
  if (none(first_tiny) && !largest.centres.empty()) {
    KMeansResult merged_largest = largest;
    first_tiny = MergeTinyClusters(input, &merged_largest);
    outliers_from = &largest;
  }
  if (none(first_tiny)) return first;
  KMeansInput rest;
  std::vector<size_t> rest_index;
  for (size_t i = 0; i < input.points.size(); ++i) {
    if (first_tiny[outliers_from->assignment[i]]) continue;
    rest.points.push_back(input.points[i]);
    if (!input.weights.empty()) rest.weights.push_back(input.weights[i]);
    rest_index.push_back(i);
  }
  absl::StatusOr<KMeansResult> second = KMeans(rest, options);
  if (!second.ok()) {  // e.g. the rest weighs nothing: the merged first run
    if (outliers_from != &*first) return first;
    *tiny = first_tiny;
    return merged;
  }
  KMeansResult result;
  result.automatic_k = true;
  result.iterations = second->iterations;
  result.centres = second->centres;
  const size_t k = second->centres.size();
  for (size_t c = 0; c < first_tiny.size(); ++c) {
    if (first_tiny[c]) result.centres.push_back(outliers_from->centres[c]);
  }
  std::vector<uint32_t> materials(k);
  for (size_t c = 0; c < k; ++c) materials[c] = static_cast<uint32_t>(c);
  result.assignment.assign(input.points.size(), 0);
  std::vector<bool> is_rest(input.points.size(), false);
  for (size_t j = 0; j < rest_index.size(); ++j) {
    result.assignment[rest_index[j]] = second->assignment[j];
    is_rest[rest_index[j]] = true;
  }
  for (size_t i = 0; i < input.points.size(); ++i) {
    float d;
    if (!is_rest[i]) result.assignment[i] = Nearest(input.points[i], result.centres, materials, &d);
  }
  result.sizes.assign(result.centres.size(), 0);
  result.inertia = 0.0;
  for (size_t i = 0; i < input.points.size(); ++i) {
    ++result.sizes[result.assignment[i]];
    result.inertia +=
        static_cast<double>(Weight(input, i)) * Distance2(input.points[i], result.centres[result.assignment[i]]);
  }
  *tiny = MergeTinyClusters(input, &result);
  for (size_t c = k; c < result.centres.size(); ++c) (*tiny)[c] = true;
  for (size_t c = 0; c < result.centres.size(); ++c) result.names.push_back(absl::StrCat("cluster ", c));
  return result;
}

}  // namespace mvbrdf::cluster
