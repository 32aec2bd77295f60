// Chart growth by normal deviation and the per-chart overlap split.
#include "core/atlas/charts.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <tuple>
#include <utility>

namespace mvbrdf::atlas::internal {
namespace {

constexpr int32_t kNoChart = -1;
constexpr double kPi = 3.14159265358979323846;

// Edge function: twice the signed area of (a, b, p); positive when p is to the
// left of a->b (counter-clockwise).
double Edge(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& p) {
  return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
}

// True when some edge of `a` has every vertex of `b` on its outside (or on it,
// up to `tolerance`).
bool SeparatedByEdgeOf(const glm::dvec2 a[3], const glm::dvec2 b[3], double tolerance) {
  for (int k = 0; k < 3; ++k) {
    const glm::dvec2& p = a[k];
    const glm::dvec2& q = a[(k + 1) % 3];
    if (Edge(p, q, b[0]) <= tolerance && Edge(p, q, b[1]) <= tolerance && Edge(p, q, b[2]) <= tolerance) return true;
  }
  return false;
}

// Orthonormal (u, v) with u x v = n, for a unit n.
void PlaneBasis(const glm::dvec3& n, glm::dvec3* u, glm::dvec3* v) {
  // Cross with the world axis least aligned with n: well conditioned.
  // The margin keeps the choice away from ties: a normal along an axis up to
  // rounding (a lathe's cap) gets the same basis whatever the mesh's units.
  constexpr double kMargin = 1e-3;
  const glm::dvec3 an = glm::abs(n);
  glm::dvec3 helper(0.0);
  if (an.x <= std::min(an.y, an.z) + kMargin) {
    helper.x = 1.0;
  } else if (an.y <= an.z + kMargin) {
    helper.y = 1.0;
  } else {
    helper.z = 1.0;
  }
  *u = glm::normalize(glm::cross(helper, n));
  *v = glm::cross(n, *u);
}

Chart MakeChart(const glm::dvec3& normal, const glm::dvec3& origin) {
  Chart chart;
  chart.normal = normal;
  PlaneBasis(normal, &chart.axis_u, &chart.axis_v);
  chart.origin = origin;
  return chart;
}

glm::dvec3 Centroid(const scene::MeshTopology& topology, const scene::FramePositions& positions, uint32_t t) {
  const glm::uvec3& f = topology.file_triangles[t];
  return (glm::dvec3(positions[f.x]) + glm::dvec3(positions[f.y]) + glm::dvec3(positions[f.z])) / 3.0;
}

// Uniform grid over a chart's projection, holding the triangles accepted so
// far into the current (sub-)chart, to find the candidates a new triangle
// could overlap in O(local) time.
class TriangleGrid {
 public:
  TriangleGrid(const glm::dvec2& lo, const glm::dvec2& hi, size_t num_triangles) : lo_(lo) {
    const glm::dvec2 extent = hi - lo;
    // About one cell per triangle, square cells, at most kMaxCells per side.
    const double longest = std::max(extent.x, extent.y);
    const double cell = std::max(
        std::sqrt(extent.x * extent.y / static_cast<double>(std::max<size_t>(1, num_triangles))), longest / kMaxCells);
    if (!(cell > 0.0)) {  // everything in one point: one cell
      inv_cell_ = glm::dvec2(0.0);
    } else {
      nx_ = std::clamp(static_cast<int>(std::ceil(extent.x / cell)), 1, kMaxCells);
      ny_ = std::clamp(static_cast<int>(std::ceil(extent.y / cell)), 1, kMaxCells);
      inv_cell_ = glm::dvec2(1.0 / cell);
    }
    cells_.resize(static_cast<size_t>(nx_) * ny_);
  }

  // Cell range [x0, x1] x [y0, y1] of a bounding box (clamped in double
  // before the cast, so that no value is out of int range).
  void Range(const glm::dvec2& lo, const glm::dvec2& hi, int* x0, int* y0, int* x1, int* y1) const {
    *x0 = Cell(lo.x - lo_.x, inv_cell_.x, nx_);
    *y0 = Cell(lo.y - lo_.y, inv_cell_.y, ny_);
    *x1 = Cell(hi.x - lo_.x, inv_cell_.x, nx_);
    *y1 = Cell(hi.y - lo_.y, inv_cell_.y, ny_);
  }

  void Insert(uint32_t id, const glm::dvec2& lo, const glm::dvec2& hi) {
    int x0, y0, x1, y1;
    Range(lo, hi, &x0, &y0, &x1, &y1);
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        std::vector<uint32_t>& cell = cells_[static_cast<size_t>(y) * nx_ + x];
        if (cell.empty()) touched_.push_back(static_cast<size_t>(y) * nx_ + x);
        cell.push_back(id);
      }
    }
  }

  // Calls visit(id) for each id in the cells of the box (ids may repeat).
  template <typename Visit>
  bool Any(const glm::dvec2& lo, const glm::dvec2& hi, Visit&& visit) const {
    int x0, y0, x1, y1;
    Range(lo, hi, &x0, &y0, &x1, &y1);
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        for (uint32_t id : cells_[static_cast<size_t>(y) * nx_ + x]) {
          if (visit(id)) return true;
        }
      }
    }
    return false;
  }

  void Clear() {
    for (size_t c : touched_) cells_[c].clear();
    touched_.clear();
  }

 private:
  static constexpr int kMaxCells = 512;

  static int Cell(double offset, double inv_cell, int count) {
    return static_cast<int>(std::clamp(offset * inv_cell, 0.0, static_cast<double>(count - 1)));
  }

  glm::dvec2 lo_;
  glm::dvec2 inv_cell_;
  int nx_ = 1, ny_ = 1;
  std::vector<std::vector<uint32_t>> cells_;
  std::vector<size_t> touched_;
};

// Triangle indices sorted by decreasing area class, then index (see SizeClass).
std::vector<uint32_t> LargestFirst(std::vector<uint32_t> triangles, const std::vector<double>& area) {
  double largest = 0.0;
  for (uint32_t t : triangles) largest = std::max(largest, area[t]);
  std::vector<std::pair<int, uint32_t>> keyed;
  keyed.reserve(triangles.size());
  for (uint32_t t : triangles) keyed.emplace_back(-SizeClass(area[t], largest), t);
  std::sort(keyed.begin(), keyed.end());
  for (size_t i = 0; i < keyed.size(); ++i) triangles[i] = keyed[i].second;
  return triangles;
}

// Phase 1: normal-cone growth. Returns per triangle its chart (kNoChart for
// degenerate triangles) and per chart its unit average normal.
void GrowNormalCones(const TriangleGeometry& geometry, const TriangleAdjacency& adjacency, double cos_max,
                     std::vector<int32_t>* chart_of, std::vector<glm::dvec3>* chart_normals,
                     std::vector<std::vector<uint32_t>>* chart_triangles) {
  const size_t n = geometry.area.size();
  chart_of->assign(n, kNoChart);
  std::vector<uint32_t> order;
  order.reserve(n);
  for (uint32_t t = 0; t < n; ++t) {
    if (!geometry.degenerate[t]) order.push_back(t);
  }
  order = LargestFirst(std::move(order), geometry.area);

  std::vector<uint32_t> released;  // triangles cut from a finished chart, seeded first
  size_t next = 0;
  std::vector<uint32_t> queue;
  std::vector<uint32_t> members;
  for (;;) {
    uint32_t seed = 0;
    bool found = false;
    while (!released.empty() && !found) {
      seed = released.back();
      released.pop_back();
      found = (*chart_of)[seed] == kNoChart;
    }
    while (!found && next < order.size()) {
      seed = order[next++];
      found = (*chart_of)[seed] == kNoChart;
    }
    if (!found) break;

    const int32_t c = static_cast<int32_t>(chart_normals->size());
    members.assign(1, seed);
    (*chart_of)[seed] = c;
    glm::dvec3 sum = geometry.area[seed] * geometry.normal[seed];
    queue.clear();
    size_t head = 0;
    auto push_neighbors = [&](uint32_t t) {
      for (uint32_t i = adjacency.offsets[t]; i < adjacency.offsets[t + 1]; ++i) {
        const uint32_t nb = adjacency.neighbors[i];
        if ((*chart_of)[nb] == kNoChart && !geometry.degenerate[nb]) queue.push_back(nb);
      }
    };
    push_neighbors(seed);
    // Breadth first, so that charts grow roughly round. A triangle rejected
    // now may be queued again by another neighbour once the average moved.
    while (head < queue.size()) {
      const uint32_t t = queue[head++];
      if ((*chart_of)[t] != kNoChart) continue;
      if (glm::dot(geometry.normal[t], glm::normalize(sum)) < cos_max) continue;
      (*chart_of)[t] = c;
      members.push_back(t);
      sum += geometry.area[t] * geometry.normal[t];
      push_neighbors(t);
    }

    // The running average drifted while growing: triangles accepted early may
    // be outside the cone of the final average, which is the projection
    // direction. Release them (each round moves the average less) so that the
    // bound holds for every triangle of the chart.
    for (;;) {
      const glm::dvec3 avg = glm::normalize(sum);
      if (glm::dot(geometry.normal[seed], avg) < cos_max) {
        // Degenerate case (the seed itself is outside): keep the seed alone.
        for (uint32_t t : members) {
          if (t != seed) {
            (*chart_of)[t] = kNoChart;
            released.push_back(t);
          }
        }
        members.assign(1, seed);
        sum = geometry.area[seed] * geometry.normal[seed];
        break;
      }
      size_t kept = 0;
      for (uint32_t t : members) {
        if (glm::dot(geometry.normal[t], avg) >= cos_max) {
          members[kept++] = t;
        } else {
          (*chart_of)[t] = kNoChart;
          released.push_back(t);
        }
      }
      if (kept == members.size()) break;
      members.resize(kept);
      sum = glm::dvec3(0.0);
      for (uint32_t t : members) sum += geometry.area[t] * geometry.normal[t];
    }
    chart_normals->push_back(glm::normalize(sum));
    chart_triangles->push_back(members);
  }
}

// Phase 1b: growth leaves small charts behind (triangles that no
// neighbouring chart's running average accepted at the time, or released ones;
// on samba over half the charts have <= 3 triangles). Each costs a box and a
// gutter, so their triangles move to an edge-adjacent larger chart whose
// *final* normal accepts them; that chart's normal is then kept as it is (not
// re-averaged), so the cone bound still holds for every member.
void AbsorbSmallCharts(const TriangleGeometry& geometry, const TriangleAdjacency& adjacency, double cos_max,
                       const std::vector<glm::dvec3>& chart_normals, std::vector<int32_t>* chart_of,
                       std::vector<std::vector<uint32_t>>* chart_triangles) {
  constexpr size_t kSmall = 8;  // triangles
  const size_t num_charts = chart_triangles->size();
  std::vector<uint8_t> small(num_charts, 0);
  std::vector<uint8_t> loose(chart_of->size(), 0);
  for (size_t c = 0; c < num_charts; ++c) {
    if ((*chart_triangles)[c].size() >= kSmall) continue;
    small[c] = 1;
    for (uint32_t t : (*chart_triangles)[c]) loose[t] = 1;
  }
  std::vector<uint32_t> queue;
  for (uint32_t t = 0; t < loose.size(); ++t) {
    if (loose[t]) queue.push_back(t);
  }
  for (size_t head = 0; head < queue.size(); ++head) {
    const uint32_t t = queue[head];
    if (!loose[t]) continue;
    int32_t best = kNoChart;
    double best_dot = cos_max;
    for (uint32_t i = adjacency.offsets[t]; i < adjacency.offsets[t + 1]; ++i) {
      const uint32_t nb = adjacency.neighbors[i];
      const int32_t c = (*chart_of)[nb];
      if (c == kNoChart || loose[nb] || small[c]) continue;
      const double dot = glm::dot(geometry.normal[t], chart_normals[c]);
      if (dot >= best_dot) {
        best_dot = dot;
        best = c;
      }
    }
    if (best == kNoChart) continue;
    (*chart_of)[t] = best;
    loose[t] = 0;
    // Its loose neighbours may now be adjacent to an accepting chart.
    for (uint32_t i = adjacency.offsets[t]; i < adjacency.offsets[t + 1]; ++i) {
      if (loose[adjacency.neighbors[i]]) queue.push_back(adjacency.neighbors[i]);
    }
  }
  // Rebuild the member lists (what stayed loose stays in its small chart; a
  // small chart may now be disconnected, which phase 2 splits).
  for (auto& members : *chart_triangles) members.clear();
  for (uint32_t t = 0; t < chart_of->size(); ++t) {
    if ((*chart_of)[t] != kNoChart) (*chart_triangles)[(*chart_of)[t]].push_back(t);
  }
}

}  // namespace

int SizeClass(double value, double largest) {
  if (!(value > 0.0 && largest > 0.0)) return std::numeric_limits<int>::min() / 2;
  return static_cast<int>(std::floor(16.0 * std::log2(value / largest) + 0.5));
}

TriangleGeometry ComputeTriangleGeometry(const scene::MeshTopology& topology,
                                         const scene::FramePositions& rest_positions) {
  const size_t n = topology.file_triangles.size();
  TriangleGeometry g;
  g.normal.assign(n, glm::dvec3(0.0));
  g.area.assign(n, 0.0);
  g.degenerate.assign(n, 0);
  for (size_t t = 0; t < n; ++t) {
    const glm::uvec3& f = topology.file_triangles[t];
    const glm::dvec3 a(rest_positions[f.x]), b(rest_positions[f.y]), c(rest_positions[f.z]);
    const glm::dvec3 cross = glm::cross(b - a, c - a);
    const double len = glm::length(cross);
    g.area[t] = 0.5 * len;
    if (len > 0.0 && std::isfinite(len)) {
      g.normal[t] = cross / len;
    } else {
      g.degenerate[t] = 1;
    }
  }
  for (uint32_t t : topology.zero_area_triangles) g.degenerate[t] = 1;
  return g;
}

TriangleAdjacency BuildEdgeAdjacency(const std::vector<glm::uvec3>& triangles) {
  // (min vertex, max vertex, triangle), sorted: the triangles of one edge are
  // consecutive. O(n log n), no hashing.
  struct EdgeUse {
    uint32_t lo, hi, triangle;
  };
  std::vector<EdgeUse> uses;
  uses.reserve(3 * triangles.size());
  for (uint32_t t = 0; t < triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = triangles[t][k], b = triangles[t][(k + 1) % 3];
      if (a == b) continue;  // collapsed edge: not a real edge
      uses.push_back({std::min(a, b), std::max(a, b), t});
    }
  }
  std::sort(uses.begin(), uses.end(), [](const EdgeUse& x, const EdgeUse& y) {
    return std::tie(x.lo, x.hi, x.triangle) < std::tie(y.lo, y.hi, y.triangle);
  });
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  for (size_t i = 0; i < uses.size();) {
    size_t j = i;
    while (j < uses.size() && uses[j].lo == uses[i].lo && uses[j].hi == uses[i].hi) ++j;
    for (size_t p = i; p < j; ++p) {
      for (size_t q = i; q < j; ++q) {
        if (uses[p].triangle != uses[q].triangle) pairs.emplace_back(uses[p].triangle, uses[q].triangle);
      }
    }
    i = j;
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  TriangleAdjacency adjacency;
  adjacency.offsets.assign(triangles.size() + 1, 0);
  for (const auto& p : pairs) ++adjacency.offsets[p.first + 1];
  for (size_t t = 0; t < triangles.size(); ++t) adjacency.offsets[t + 1] += adjacency.offsets[t];
  adjacency.neighbors.reserve(pairs.size());
  for (const auto& p : pairs) adjacency.neighbors.push_back(p.second);  // pairs sorted by first: CSR order
  return adjacency;
}

int ConnectedComponents(const TriangleAdjacency& adjacency, std::vector<uint32_t>* component) {
  const size_t n = adjacency.offsets.size() - 1;
  constexpr uint32_t kUnset = ~0u;
  component->assign(n, kUnset);
  std::vector<uint32_t> stack;
  uint32_t count = 0;
  for (uint32_t s = 0; s < n; ++s) {
    if ((*component)[s] != kUnset) continue;
    (*component)[s] = count;
    stack.assign(1, s);
    while (!stack.empty()) {
      const uint32_t t = stack.back();
      stack.pop_back();
      for (uint32_t i = adjacency.offsets[t]; i < adjacency.offsets[t + 1]; ++i) {
        const uint32_t nb = adjacency.neighbors[i];
        if ((*component)[nb] == kUnset) {
          (*component)[nb] = count;
          stack.push_back(nb);
        }
      }
    }
    ++count;
  }
  return static_cast<int>(count);
}

bool TrianglesOverlap(const glm::dvec2 a[3], const glm::dvec2 b[3], double tolerance) {
  // Two convex polygons have disjoint interiors iff a line through an edge of
  // one of them separates them.
  return !SeparatedByEdgeOf(a, b, tolerance) && !SeparatedByEdgeOf(b, a, tolerance);
}

std::vector<Chart> BuildCharts(const scene::MeshTopology& topology, const scene::FramePositions& rest_positions,
                               const TriangleGeometry& geometry, const TriangleAdjacency& file_adjacency,
                               double max_normal_deviation_deg) {
  const size_t n = geometry.area.size();
  const double cos_max = std::cos(max_normal_deviation_deg * kPi / 180.0);
  std::vector<int32_t> cone_of;
  std::vector<glm::dvec3> cone_normals;
  std::vector<std::vector<uint32_t>> cone_triangles;
  GrowNormalCones(geometry, file_adjacency, cos_max, &cone_of, &cone_normals, &cone_triangles);
  AbsorbSmallCharts(geometry, file_adjacency, cos_max, cone_normals, &cone_of, &cone_triangles);

  // Phase 2: re-grow each cone inside its projection. A triangle joins the
  // current sub-chart when it is edge-adjacent to it, projects with positive
  // orientation, and overlaps none of its triangles; the rest seed further
  // sub-charts on the same plane (the same plane keeps the normal bound).
  std::vector<Chart> charts;
  std::vector<int32_t> chart_of(n, kNoChart);
  std::vector<int32_t> local_of(n, -1);  // index into the current cone's arrays
  std::vector<std::array<glm::dvec2, 3>> projected;
  std::vector<glm::dvec2> box_lo, box_hi;
  std::vector<uint32_t> stamp;
  uint32_t query = 0;
  std::vector<uint32_t> queue;
  for (size_t c = 0; c < cone_triangles.size(); ++c) {
    const std::vector<uint32_t>& cone = cone_triangles[c];
    if (cone.empty()) continue;  // absorbed
    const uint32_t seed0 = cone.front();
    const Chart plane = MakeChart(cone_normals[c], Centroid(topology, rest_positions, seed0));
    if (cone.size() == 1) {
      Chart chart = plane;
      chart.triangles = cone;
      chart_of[seed0] = static_cast<int32_t>(charts.size());
      charts.push_back(std::move(chart));
      continue;
    }
    const size_t m = cone.size();
    projected.resize(m);
    box_lo.resize(m);
    box_hi.resize(m);
    stamp.assign(m, 0);
    glm::dvec2 lo(HUGE_VAL), hi(-HUGE_VAL);
    for (size_t i = 0; i < m; ++i) {
      local_of[cone[i]] = static_cast<int32_t>(i);
      const glm::uvec3& f = topology.file_triangles[cone[i]];
      for (int k = 0; k < 3; ++k) projected[i][k] = plane.Project(glm::dvec3(rest_positions[f[k]]));
      box_lo[i] = glm::min(projected[i][0], glm::min(projected[i][1], projected[i][2]));
      box_hi[i] = glm::max(projected[i][0], glm::max(projected[i][1], projected[i][2]));
      lo = glm::min(lo, box_lo[i]);
      hi = glm::max(hi, box_hi[i]);
    }
    // Edge-function tolerance: far below any texel at any sensible atlas size,
    // far above the rounding of the projection.
    const glm::dvec2 diag = hi - lo;
    const double tolerance = 1e-12 * glm::dot(diag, diag);
    TriangleGrid grid(lo, hi, m);

    auto fits = [&](uint32_t i) {
      if (Edge(projected[i][0], projected[i][1], projected[i][2]) <= tolerance) return false;
      ++query;
      return !grid.Any(box_lo[i], box_hi[i], [&](uint32_t j) {
        if (stamp[j] == query) return false;
        stamp[j] = query;
        if (box_hi[j].x < box_lo[i].x || box_hi[i].x < box_lo[j].x || box_hi[j].y < box_lo[i].y ||
            box_hi[i].y < box_lo[j].y) {
          return false;
        }
        return TrianglesOverlap(projected[i].data(), projected[j].data(), tolerance);
      });
    };

    const std::vector<uint32_t> seeds = LargestFirst(cone, geometry.area);
    for (uint32_t seed : seeds) {
      if (chart_of[seed] != kNoChart) continue;
      const int32_t id = static_cast<int32_t>(charts.size());
      Chart chart = plane;
      // A seed that does not fit alone (numerically flat in this projection)
      // still gets a chart: a single triangle cannot overlap itself.
      chart_of[seed] = id;
      chart.triangles.push_back(seed);
      grid.Insert(static_cast<uint32_t>(local_of[seed]), box_lo[local_of[seed]], box_hi[local_of[seed]]);
      queue.assign(1, seed);
      for (size_t head = 0; head < queue.size(); ++head) {
        const uint32_t t = queue[head];
        for (uint32_t k = file_adjacency.offsets[t]; k < file_adjacency.offsets[t + 1]; ++k) {
          const uint32_t nb = file_adjacency.neighbors[k];
          if (local_of[nb] < 0 || chart_of[nb] != kNoChart) continue;
          const uint32_t i = static_cast<uint32_t>(local_of[nb]);
          if (!fits(i)) continue;
          chart_of[nb] = id;
          chart.triangles.push_back(nb);
          grid.Insert(i, box_lo[i], box_hi[i]);
          queue.push_back(nb);
        }
      }
      grid.Clear();
      charts.push_back(std::move(chart));
    }
    for (uint32_t t : cone) local_of[t] = -1;
  }

  // Phase 3: degenerate triangles join the chart of an edge neighbour,
  // breadth first from the charted ones (chains of them propagate).
  std::vector<uint32_t> pending;
  for (uint32_t t = 0; t < n; ++t) {
    if (!geometry.degenerate[t]) continue;
    for (uint32_t k = file_adjacency.offsets[t]; k < file_adjacency.offsets[t + 1]; ++k) {
      if (!geometry.degenerate[file_adjacency.neighbors[k]]) {
        pending.push_back(t);
        break;
      }
    }
  }
  for (size_t head = 0; head < pending.size(); ++head) {
    const uint32_t t = pending[head];
    if (chart_of[t] != kNoChart) continue;
    for (uint32_t k = file_adjacency.offsets[t]; k < file_adjacency.offsets[t + 1]; ++k) {
      const int32_t c = chart_of[file_adjacency.neighbors[k]];
      if (c != kNoChart) {
        chart_of[t] = c;
        charts[c].triangles.push_back(t);
        break;
      }
    }
    if (chart_of[t] == kNoChart) continue;
    for (uint32_t k = file_adjacency.offsets[t]; k < file_adjacency.offsets[t + 1]; ++k) {
      const uint32_t nb = file_adjacency.neighbors[k];
      if (chart_of[nb] == kNoChart) pending.push_back(nb);
    }
  }
  // Isolated degenerate triangles (no charted neighbour at all): one chart
  // each, on any plane.
  for (uint32_t t = 0; t < n; ++t) {
    if (chart_of[t] != kNoChart) continue;
    Chart chart = MakeChart(glm::dvec3(0.0, 0.0, 1.0), Centroid(topology, rest_positions, t));
    chart.triangles.push_back(t);
    chart_of[t] = static_cast<int32_t>(charts.size());
    charts.push_back(std::move(chart));
  }
  return charts;
}

}  // namespace mvbrdf::atlas::internal
