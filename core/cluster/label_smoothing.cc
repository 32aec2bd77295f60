#include "core/cluster/label_smoothing.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace mvbrdf::cluster {

namespace {

// Maximum flow (Dinic) on a graph of n nodes with a source and a sink, for
// the binary expansion moves below.
class MaxFlow {
 public:
  MaxFlow(size_t n, size_t arcs_hint) : head_(n + 2, -1), level_(n + 2), next_arc_(n + 2), s_(n), t_(n + 1) {
    to_.reserve(2 * arcs_hint), cap_.reserve(2 * arcs_hint), next_.reserve(2 * arcs_hint);
  }
  size_t source() const { return s_; }
  size_t sink() const { return t_; }
  void AddArc(size_t from, size_t to, double cap) {
    Add(from, to, cap);
    Add(to, from, 0.0);
  }
  void Run(double epsilon) {
    epsilon_ = epsilon;
    while (Levels()) {
      for (size_t v = 0; v < head_.size(); ++v) next_arc_[v] = head_[v];
      while (Push(s_, std::numeric_limits<double>::infinity()) > epsilon_) {
      }
    }
  }
  // After Run: whether node v is on the source side of the minimum cut.
  bool SourceSide(size_t v) const { return level_[v] >= 0; }

 private:
  void Add(size_t from, size_t to, double cap) {
    to_.push_back(static_cast<uint32_t>(to));
    cap_.push_back(cap);
    next_.push_back(head_[from]);
    head_[from] = static_cast<int64_t>(to_.size() - 1);
  }
  bool Levels() {
    std::fill(level_.begin(), level_.end(), -1);
    std::vector<size_t> queue = {s_};
    level_[s_] = 0;
    for (size_t q = 0; q < queue.size(); ++q) {
      const size_t v = queue[q];
      for (int64_t a = head_[v]; a >= 0; a = next_[static_cast<size_t>(a)]) {
        const size_t w = to_[static_cast<size_t>(a)];
        if (level_[w] < 0 && cap_[static_cast<size_t>(a)] > epsilon_) level_[w] = level_[v] + 1, queue.push_back(w);
      }
    }
    return level_[t_] >= 0;
  }
  double Push(size_t v, double flow) {
    if (v == t_) return flow;
    for (int64_t& a = next_arc_[v]; a >= 0; a = next_[static_cast<size_t>(a)]) {
      const size_t arc = static_cast<size_t>(a), w = to_[arc];
      if (cap_[arc] <= epsilon_ || level_[w] != level_[v] + 1) continue;
      const double pushed = Push(w, std::min(flow, cap_[arc]));
      if (pushed > epsilon_) {
        cap_[arc] -= pushed;
        cap_[arc ^ 1] += pushed;
        return pushed;
      }
    }
    return 0.0;
  }

  std::vector<int64_t> head_;
  std::vector<uint32_t> to_;
  std::vector<double> cap_;
  std::vector<int64_t> next_;
  std::vector<int> level_;
  std::vector<int64_t> next_arc_;
  size_t s_, t_;
  double epsilon_ = 0.0;
};

}  // namespace

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
  const double lambda = options.smoothness * result.data_scale;  // in raw cost units
  const auto& cost = raw_cost;

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
  // Labels to expand: those the clustering gave some point (an empty
  // cluster's centre is nobody's nearest, and stays empty).
  std::vector<uint32_t> present;
  for (uint32_t k : labels) {
    if (std::find(present.begin(), present.end(), k) == present.end()) present.push_back(k);
  }
  std::sort(present.begin(), present.end());
  auto energy = [&]() {
    double e = 0.0;
    for (size_t i = 0; i < n; ++i) e += cost(i, l[i]);
    for (const auto& [a, b] : edges) e += l[a] != l[b] ? lambda : 0.0;
    return e;
  };
  double current = energy();
  // Alpha-expansion (Boykov, Veksler and Zabih 2001): for each label alpha,
  // the best move that lets any point switch to alpha is a minimum cut; a
  // cycle over the labels that lowers the energy by no more than a
  // millionth ends the solve.
  const double epsilon = 1e-12 * std::max(current, 1e-300);
  for (result.iterations = 0; result.iterations < options.max_iterations;) {
    ++result.iterations;
    const double cycle_start = current;
    for (uint32_t alpha : present) {
      MaxFlow flow(n, n + edges.size());
      // Per point the coefficient of x (1: switch to alpha) in its unary terms.
      std::vector<double> unary(n, 0.0);
      std::vector<uint8_t> fixed(n, 0);
      for (size_t i = 0; i < n; ++i) {
        if (l[i] == alpha) {
          fixed[i] = 1;
        } else if (!allowed(i, alpha)) {
          fixed[i] = 1;
        } else {
          unary[i] = cost(i, alpha) - cost(i, l[i]);
        }
      }
      for (const auto& [a, b] : edges) {
        // Pairwise V(x_a, x_b): A = V(0,0), B = V(0,1), C = V(1,0), D = V(1,1) = 0
        // = A + (C - A) x_a + (D - C) x_b + (B + C - A - D)(1 - x_a) x_b.
        // A fixed point is x = 0 when it keeps a label other than alpha and
        // counts as alpha when it has it (its x is irrelevant).
        const bool fa = fixed[a], fb = fixed[b];
        const uint32_t la = l[a], lb = l[b];
        if (fa && fb) continue;
        if (fa || fb) {
          // One free point f next to a fixed point holding label m: cost
          // lambda [l_f != m] when f keeps, lambda [alpha != m] when it switches.
          const uint32_t f = fa ? b : a;
          const uint32_t m = fa ? la : lb;
          unary[f] += (alpha != m ? lambda : 0.0) - (l[f] != m ? lambda : 0.0);
          continue;
        }
        const double A = la != lb ? lambda : 0.0, B = la != alpha ? lambda : 0.0, C = alpha != lb ? lambda : 0.0;
        unary[a] += C - A;
        unary[b] += -C;
        const double w = B + C - A;  // >= 0: Potts is a metric
        if (w > 0.0) flow.AddArc(a, b, w);
      }
      for (size_t i = 0; i < n; ++i) {
        if (fixed[i]) continue;
        if (unary[i] > 0.0) {
          flow.AddArc(flow.source(), i, unary[i]);  // paid when i switches (sink side)
        } else if (unary[i] < 0.0) {
          flow.AddArc(i, flow.sink(), -unary[i]);  // paid when i keeps (source side)
        }
      }
      flow.Run(epsilon);
      std::vector<uint32_t> before = l;
      for (size_t i = 0; i < n; ++i) {
        if (!fixed[i] && !flow.SourceSide(i)) l[i] = alpha;
      }
      const double after = energy();
      if (after < current) {
        current = after;
      } else {
        l = std::move(before);  // rounding: never a worse labelling
      }
    }
    if (!(current < cycle_start * (1.0 - 1e-6))) break;
  }
  for (size_t i = 0; i < n; ++i) result.relabelled += l[i] != labels[i] ? 1u : 0u;
  return result;
}

}  // namespace mvbrdf::cluster
