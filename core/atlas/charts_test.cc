#include "core/atlas/charts.h"

#include <gtest/gtest.h>

namespace mvbrdf::atlas::internal {
namespace {

TEST(TrianglesOverlapTest, SharedEdgeOrVertexIsNotOverlap) {
  const glm::dvec2 a[3] = {{0, 0}, {1, 0}, {0, 1}};
  const glm::dvec2 across_edge[3] = {{1, 0}, {1, 1}, {0, 1}};
  const glm::dvec2 at_vertex[3] = {{1, 0}, {2, 0}, {2, 1}};
  const glm::dvec2 inside[3] = {{0.1, 0.1}, {0.3, 0.1}, {0.1, 0.3}};
  const glm::dvec2 crossing[3] = {{0.4, -0.5}, {0.6, -0.5}, {0.5, 2.0}};  // no vertex inside either
  const glm::dvec2 apart[3] = {{2, 2}, {3, 2}, {2, 3}};
  EXPECT_FALSE(TrianglesOverlap(a, across_edge, 0.0));
  EXPECT_FALSE(TrianglesOverlap(a, at_vertex, 0.0));
  EXPECT_TRUE(TrianglesOverlap(a, inside, 0.0));
  EXPECT_TRUE(TrianglesOverlap(inside, a, 0.0));
  EXPECT_TRUE(TrianglesOverlap(a, crossing, 0.0));
  EXPECT_FALSE(TrianglesOverlap(a, apart, 0.0));
}

TEST(EdgeAdjacencyTest, ManifoldAndNonManifoldEdges) {
  // Three triangles on edge (0, 1) (a "book"), one more on edge (1, 2).
  const std::vector<glm::uvec3> tris = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}, {2, 1, 5}};
  const TriangleAdjacency adj = BuildEdgeAdjacency(tris);
  auto neighbors = [&](uint32_t t) {
    return std::vector<uint32_t>(adj.neighbors.begin() + adj.offsets[t], adj.neighbors.begin() + adj.offsets[t + 1]);
  };
  EXPECT_EQ(neighbors(0), (std::vector<uint32_t>{1, 2, 3}));
  EXPECT_EQ(neighbors(1), (std::vector<uint32_t>{0, 2}));
  EXPECT_EQ(neighbors(3), (std::vector<uint32_t>{0}));
  std::vector<uint32_t> component;
  EXPECT_EQ(ConnectedComponents(adj, &component), 1);
  const TriangleAdjacency split = BuildEdgeAdjacency({{0, 1, 2}, {3, 4, 5}, {2, 1, 6}});
  EXPECT_EQ(ConnectedComponents(split, &component), 2);
  EXPECT_EQ(component, (std::vector<uint32_t>{0, 1, 0}));
}

TEST(BuildChartsTest, NormalsStayInTheConeAndBasisIsRightHanded) {
  // A folded strip: four unit squares (8 triangles) bent by 30 degrees at
  // each crease; with a 50 degree threshold no chart spans more than 100
  // degrees of normals.
  scene::MeshTopology topo;
  scene::FramePositions pos;
  glm::dvec2 p(0.0);  // (x, y) of the crease line, the strip runs along z
  double angle = 0.0;
  for (int i = 0; i <= 4; ++i) {
    pos.emplace_back(p.x, p.y, 0.0);
    pos.emplace_back(p.x, p.y, 1.0);
    p += glm::dvec2(std::cos(angle), std::sin(angle));
    angle += 30.0 * 3.14159265358979 / 180.0;
  }
  for (uint32_t i = 0; i < 4; ++i) {
    const uint32_t a = 2 * i, b = a + 1, c = a + 2, d = a + 3;
    topo.file_triangles.emplace_back(a, c, d);
    topo.file_triangles.emplace_back(a, d, b);
  }
  topo.triangles = topo.file_triangles;
  topo.num_file_vertices = static_cast<uint32_t>(pos.size());
  for (uint32_t i = 0; i < pos.size(); ++i) topo.render_to_file_vertex.push_back(i);
  const TriangleGeometry geometry = ComputeTriangleGeometry(topo, pos);
  const std::vector<Chart> charts = BuildCharts(topo, pos, geometry, BuildEdgeAdjacency(topo.file_triangles), 50.0);
  ASSERT_GE(charts.size(), 2u);
  size_t total = 0;
  for (const Chart& chart : charts) {
    EXPECT_NEAR(glm::dot(glm::cross(chart.axis_u, chart.axis_v), chart.normal), 1.0, 1e-12);
    for (uint32_t t : chart.triangles) {
      EXPECT_GE(glm::dot(geometry.normal[t], chart.normal), std::cos(50.0 * 3.14159265358979 / 180.0) - 1e-12);
    }
    total += chart.triangles.size();
  }
  EXPECT_EQ(total, 8u);
}

}  // namespace
}  // namespace mvbrdf::atlas::internal
