#include "core/atlas/texel_graph.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

namespace mvbrdf::atlas {
namespace {

// Unit cube over its 8 file vertices (no UVs): BuildAtlas cuts it into one
// chart per face, so every cube edge is a seam.
scene::MeshTopology CubeTopology(scene::FramePositions* positions) {
  *positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  const int quads[6][4] = {{0, 3, 2, 1}, {1, 2, 6, 5}, {4, 5, 6, 7}, {0, 1, 5, 4}, {3, 7, 6, 2}, {0, 4, 7, 3}};
  scene::MeshTopology topo;
  for (const auto& q : quads) {
    topo.triangles.emplace_back(q[0], q[1], q[2]);
    topo.triangles.emplace_back(q[0], q[2], q[3]);
  }
  topo.file_triangles = topo.triangles;
  topo.num_file_vertices = 8;
  for (uint32_t i = 0; i < 8; ++i) topo.render_to_file_vertex.push_back(i);
  return topo;
}

// The surface point under a texel's centre (barycentric in its triangle's UVs).
glm::dvec3 SurfacePoint(const Atlas& atlas, const scene::FramePositions& positions, uint32_t texel) {
  const int row = static_cast<int>(texel / static_cast<uint32_t>(atlas.size));
  const int col = static_cast<int>(texel % static_cast<uint32_t>(atlas.size));
  const int32_t t = atlas.triangle_id.at<int32_t>(row, col);
  const glm::dvec2 p((col + 0.5) / atlas.size, 1.0 - (row + 0.5) / atlas.size);
  const glm::uvec3 r = atlas.topology.triangles[static_cast<size_t>(t)];
  const glm::dvec2 a(atlas.topology.uvs[r[0]]), b(atlas.topology.uvs[r[1]]), c(atlas.topology.uvs[r[2]]);
  auto cross = [](glm::dvec2 u, glm::dvec2 v) { return u.x * v.y - u.y * v.x; };
  const double area = cross(b - a, c - a);
  const double wb = cross(p - a, c - a) / area, wc = cross(b - a, p - a) / area;
  const glm::uvec3 f = atlas.topology.file_triangles[static_cast<size_t>(t)];
  return (1.0 - wb - wc) * glm::dvec3(positions[f[0]]) + wb * glm::dvec3(positions[f[1]]) +
         wc * glm::dvec3(positions[f[2]]);
}

uint32_t Find(std::vector<uint32_t>* parent, uint32_t x) {
  while ((*parent)[x] != x) x = (*parent)[x] = (*parent)[(*parent)[x]];
  return x;
}

TEST(TexelEdgesTest, CubeNeighboursAreSurfaceNeighboursAndTheSeamsJoinTheFaces) {
  scene::FramePositions positions;
  const scene::MeshTopology topo = CubeTopology(&positions);
  AtlasOptions options;
  options.size = 64;
  auto atlas = BuildAtlas(topo, positions, options);
  ASSERT_TRUE(atlas.ok()) << atlas.status();
  ASSERT_EQ(atlas->stats.num_charts, 6);
  const TexelEdges graph = BuildTexelEdges(*atlas);
  EXPECT_GT(graph.chart_edges, 0u);
  EXPECT_GT(graph.seam_edges, 0u);
  EXPECT_EQ(graph.edges.size(), graph.chart_edges + graph.seam_edges);
  // One texel's side on the surface (world units).
  const double texel = 1.0 / atlas->stats.texels_per_world_unit;
  const uint32_t n = static_cast<uint32_t>(atlas->size * atlas->size);
  std::vector<uint32_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0u);
  double farthest = 0.0;
  for (const auto& [a, b] : graph.edges) {
    ASSERT_LT(a, b);
    ASSERT_GE(atlas->triangle_id.at<int32_t>(static_cast<int>(a / 64), static_cast<int>(a % 64)), 0);
    ASSERT_GE(atlas->triangle_id.at<int32_t>(static_cast<int>(b / 64), static_cast<int>(b % 64)), 0);
    farthest = std::max(farthest, glm::length(SurfacePoint(*atlas, positions, a) - SurfacePoint(*atlas, positions, b)));
    parent[Find(&parent, a)] = Find(&parent, b);
  }
  // Neighbours are near on the surface: a chart neighbour is one texel away,
  // a seam pair at most a texel's diagonal on each side of the edge.
  EXPECT_LE(farthest, 2.0 * std::sqrt(2.0) * texel) << "texel " << texel;
  // The cube is one surface: with the seams its covered texels form one
  // component (without them, one per face).
  uint32_t root = n, components = 0;
  for (uint32_t t = 0; t < n; ++t) {
    if (atlas->triangle_id.at<int32_t>(static_cast<int>(t / 64), static_cast<int>(t % 64)) < 0) continue;
    if (Find(&parent, t) == t) ++components, root = t;
  }
  EXPECT_EQ(components, 1u) << "root " << root;
}

TEST(TexelEdgesTest, EmptyWithoutAnAtlas) { EXPECT_TRUE(BuildTexelEdges(Atlas{}).edges.empty()); }

}  // namespace
}  // namespace mvbrdf::atlas
