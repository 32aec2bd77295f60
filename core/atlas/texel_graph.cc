#include "core/atlas/texel_graph.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include "core/atlas/charts.h"

namespace mvbrdf::atlas {
namespace {

// Texel coordinates (column, row) of a UV: texel (i, j) has its centre at
// u = (i + 0.5) / size, v = 1 - (j + 0.5) / size.
glm::dvec2 TexelCoordinates(const glm::vec2& uv, int size) {
  return {static_cast<double>(uv.x) * size - 0.5, (1.0 - static_cast<double>(uv.y)) * size - 0.5};
}

// The texel of `triangle` whose centre is nearest to p (texel coordinates);
// size * size when it has none.
uint32_t NearestTexel(const Atlas& atlas, uint32_t triangle, const glm::dvec2& p) {
  const uint32_t none = static_cast<uint32_t>(atlas.size) * static_cast<uint32_t>(atlas.size);
  uint32_t best = none;
  double best_d = std::numeric_limits<double>::infinity();
  for (uint32_t t : atlas.triangle_texels[triangle]) {
    const double dx = static_cast<double>(t % static_cast<uint32_t>(atlas.size)) - p.x;
    const double dy = static_cast<double>(t / static_cast<uint32_t>(atlas.size)) - p.y;
    if (dx * dx + dy * dy < best_d) best_d = dx * dx + dy * dy, best = t;
  }
  return best;
}

}  // namespace

TexelEdges BuildTexelEdges(const Atlas& atlas) {
  TexelEdges out;
  const scene::MeshTopology& topo = atlas.topology;
  const int size = atlas.size;
  if (size <= 0 || !topo.has_uvs() || atlas.triangle_id.rows != size || atlas.triangle_id.cols != size) return out;
  const size_t num_triangles = topo.triangles.size();
  // Charts: components over render-vertex edges (the UVs are continuous
  // inside one).
  std::vector<uint32_t> chart;
  internal::ConnectedComponents(internal::BuildEdgeAdjacency(topo.triangles), &chart);
  auto tri_at = [&](int row, int col) { return atlas.triangle_id.at<int32_t>(row, col); };
  for (int row = 0; row < size; ++row) {
    for (int col = 0; col < size; ++col) {
      const int32_t a = tri_at(row, col);
      if (a < 0) continue;
      const uint32_t ta = static_cast<uint32_t>(row * size + col);
      if (col + 1 < size) {
        const int32_t b = tri_at(row, col + 1);
        if (b >= 0 && chart[static_cast<size_t>(a)] == chart[static_cast<size_t>(b)]) {
          out.edges.emplace_back(ta, ta + 1);
          ++out.chart_edges;
        }
      }
      if (row + 1 < size) {
        const int32_t b = tri_at(row + 1, col);
        if (b >= 0 && chart[static_cast<size_t>(a)] == chart[static_cast<size_t>(b)]) {
          out.edges.emplace_back(ta, ta + static_cast<uint32_t>(size));
          ++out.chart_edges;
        }
      }
    }
  }
  // Seams: mesh edges over file vertices, (low, high, triangle, corner of low).
  std::vector<std::tuple<uint32_t, uint32_t, uint32_t, int>> file_edges;
  file_edges.reserve(3 * num_triangles);
  for (size_t t = 0; t < num_triangles && t < topo.file_triangles.size(); ++t) {
    for (int e = 0; e < 3; ++e) {
      const uint32_t a = topo.file_triangles[t][e], b = topo.file_triangles[t][(e + 1) % 3];
      if (a == b) continue;
      file_edges.emplace_back(std::min(a, b), std::max(a, b), static_cast<uint32_t>(t), a < b ? e : (e + 1) % 3);
    }
  }
  std::sort(file_edges.begin(), file_edges.end());
  const uint32_t none = static_cast<uint32_t>(size) * static_cast<uint32_t>(size);
  const size_t chart_count = out.edges.size();
  auto covered = [&](uint32_t t) {
    return tri_at(static_cast<int>(t / static_cast<uint32_t>(size)),
                  static_cast<int>(t % static_cast<uint32_t>(size))) >= 0;
  };
  for (size_t i = 0; i < file_edges.size();) {
    size_t j = i;
    while (j < file_edges.size() && std::get<0>(file_edges[j]) == std::get<0>(file_edges[i]) &&
           std::get<1>(file_edges[j]) == std::get<1>(file_edges[i])) {
      ++j;
    }
    for (size_t p = i; p < j; ++p) {
      for (size_t q = p + 1; q < j; ++q) {
        const uint32_t t1 = std::get<2>(file_edges[p]), t2 = std::get<2>(file_edges[q]);
        // The edge's render vertices in each triangle, from its low file
        // vertex to its high one.
        const glm::uvec3& r1 = topo.triangles[t1];
        const glm::uvec3& r2 = topo.triangles[t2];
        const int c1 = std::get<3>(file_edges[p]), c2 = std::get<3>(file_edges[q]);
        // Corner of the high vertex: the other end of the edge in each triangle.
        auto other = [&](size_t t, int c, uint32_t high) {
          for (int k = 1; k < 3; ++k) {
            if (topo.file_triangles[t][(c + k) % 3] == high) return (c + k) % 3;
          }
          return c;
        };
        const uint32_t high = std::get<1>(file_edges[p]);
        const int h1 = other(t1, c1, high), h2 = other(t2, c2, high);
        if (r1[c1] == r2[c2] && r1[h1] == r2[h2]) continue;  // the same render vertices: inside a chart
        const glm::dvec2 a1 = TexelCoordinates(topo.uvs[r1[c1]], size), b1 = TexelCoordinates(topo.uvs[r1[h1]], size);
        const glm::dvec2 a2 = TexelCoordinates(topo.uvs[r2[c2]], size), b2 = TexelCoordinates(topo.uvs[r2[h2]], size);
        const double length = std::max(glm::length(b1 - a1), glm::length(b2 - a2));
        const int steps = std::max(1, static_cast<int>(std::ceil(length)));
        for (int s = 0; s < steps; ++s) {
          const double w = (s + 0.5) / steps;
          const uint32_t x = NearestTexel(atlas, t1, a1 + w * (b1 - a1));
          const uint32_t y = NearestTexel(atlas, t2, a2 + w * (b2 - a2));
          if (x == none || y == none || x == y) continue;
          if (!covered(x) || !covered(y)) continue;
          out.edges.emplace_back(std::min(x, y), std::max(x, y));
        }
      }
    }
    i = j;
  }
  // Chart edges are distinct already; seam pairs repeat (neighbouring sample
  // points share their nearest texels) and may coincide with chart edges.
  std::sort(out.edges.begin(), out.edges.end());
  out.edges.erase(std::unique(out.edges.begin(), out.edges.end()), out.edges.end());
  out.seam_edges = out.edges.size() - chart_count;
  return out;
}

}  // namespace mvbrdf::atlas
