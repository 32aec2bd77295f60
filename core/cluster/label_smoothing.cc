#include "core/cluster/label_smoothing.h"

#include <algorithm>
#include <cmath>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace mvbrdf::cluster {

absl::StatusOr<LabelSmoothingResult> SmoothLabels(const KMeansInput& input, const std::vector<glm::vec3>& centres,
                                                  const std::vector<uint32_t>& labels,
                                                  const std::vector<std::pair<uint32_t, uint32_t>>& edges,
                                                  const LabelSmoothingOptions& options) {
  const size_t n = input.points.size();
  if (!(std::isfinite(options.smoothness) && options.smoothness >= 0.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("cluster smoothness: expected a finite number >= 0, got ", options.smoothness));
  }
  if (labels.size() != n || (!input.weights.empty() && input.weights.size() != n) ||
      (!input.segment.empty() && input.segment.size() != n)) {
    return absl::InvalidArgumentError(absl::StrCat("label smoothing: ", n, " points but ", labels.size(), " labels, ",
                                                   input.weights.size(), " weights, ", input.segment.size(),
                                                   " segments"));
  }
  for (uint32_t l : labels) {
    if (l >= centres.size()) {
      return absl::InvalidArgumentError(absl::StrCat("label smoothing: label ", l, " of ", centres.size()));
    }
  }
  for (uint32_t s : input.segment) {
    if (s >= input.allowed_clusters.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat("label smoothing: segment ", s, " of ", input.allowed_clusters.size()));
    }
  }
  for (const auto& [a, b] : edges) {
    if (a >= n || b >= n || a == b) {
      return absl::InvalidArgumentError(absl::StrCat("label smoothing: edge (", a, ", ", b, ") of ", n, " points"));
    }
  }
  LabelSmoothingResult result;
  result.labels = labels;
  if (options.smoothness == 0.0 || n == 0 || edges.empty()) return result;

  // Data costs relative to the typical point's.
  double mean_w = 0.0;
  for (size_t i = 0; i < n; ++i) mean_w += input.weights.empty() ? 1.0 : input.weights[i];
  mean_w /= static_cast<double>(n);
  if (!(mean_w > 0.0)) return result;
  std::vector<double> w(n);
  for (size_t i = 0; i < n; ++i) w[i] = (input.weights.empty() ? 1.0 : input.weights[i]) / mean_w;
  auto raw_cost = [&](size_t i, uint32_t k) {
    const glm::dvec3 d = glm::dvec3(input.points[i]) - glm::dvec3(centres[k]);
    return w[i] * glm::dot(d, d);
  };
  {
    std::vector<double> own(n);
    for (size_t i = 0; i < n; ++i) own[i] = raw_cost(i, labels[i]);
    std::nth_element(own.begin(), own.begin() + static_cast<std::ptrdiff_t>(n / 2), own.end());
    result.data_scale = own[n / 2];
    if (!(result.data_scale > 0.0)) {  // most points on their centres: the mean
      double sum = 0.0;
      for (double c : own) sum += c;
      result.data_scale = sum / static_cast<double>(n);
    }
  }
  if (!(result.data_scale > 0.0) || !std::isfinite(result.data_scale)) return result;  // every point on its centre
  const double lambda = options.smoothness * result.data_scale;                        // in raw cost units

  // Neighbours (CSR).
  std::vector<uint32_t> offsets(n + 1, 0), neighbours(2 * edges.size());
  for (const auto& [a, b] : edges) ++offsets[a + 1], ++offsets[b + 1];
  for (size_t i = 0; i < n; ++i) offsets[i + 1] += offsets[i];
  {
    std::vector<uint32_t> fill(offsets.begin(), offsets.end() - 1);
    for (const auto& [a, b] : edges) neighbours[fill[a]++] = b, neighbours[fill[b]++] = a;
  }
  auto allowed = [&](size_t i, uint32_t k) {
    if (input.segment.empty()) return true;
    const std::vector<uint32_t>& ok = input.allowed_clusters[input.segment[i]];
    return ok.empty() || std::find(ok.begin(), ok.end(), k) != ok.end();
  };
  std::vector<uint32_t>& l = result.labels;
  std::vector<uint32_t> candidates;
  for (result.iterations = 0; result.iterations < options.max_iterations;) {
    ++result.iterations;
    uint64_t changed = 0;
    for (size_t i = 0; i < n; ++i) {
      candidates.assign(1, l[i]);
      for (uint32_t j = offsets[i]; j < offsets[i + 1]; ++j) {
        const uint32_t k = l[neighbours[j]];
        if (std::find(candidates.begin(), candidates.end(), k) == candidates.end() && allowed(i, k)) {
          candidates.push_back(k);
        }
      }
      if (candidates.size() == 1) continue;
      uint32_t best = l[i];
      double best_e = 0.0;
      for (size_t c = 0; c < candidates.size(); ++c) {
        const uint32_t k = candidates[c];
        uint32_t unlike = 0;
        for (uint32_t j = offsets[i]; j < offsets[i + 1]; ++j) unlike += l[neighbours[j]] != k ? 1u : 0u;
        const double e = raw_cost(i, k) + lambda * unlike;
        if (c == 0 || e < best_e) best = k, best_e = e;
      }
      if (best != l[i]) l[i] = best, ++changed;
    }
    if (changed == 0) break;
  }
  for (size_t i = 0; i < n; ++i) result.relabelled += l[i] != labels[i] ? 1u : 0u;
  return result;
}

}  // namespace mvbrdf::cluster
