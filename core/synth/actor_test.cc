#include "core/synth/actor.h"

#include <map>
#include <set>

#include <gtest/gtest.h>

namespace mvbrdf::synth {
namespace {

TEST(ActorTest, ClosedOrientedMeshWithThreeMaterials) {
  const Actor actor = MakeActor();
  const auto& topo = actor.topology;
  ASSERT_GT(topo.triangles.size(), 5000u);
  EXPECT_EQ(topo.triangles.size(), actor.triangle_material.size());
  EXPECT_EQ(topo.triangles.size(), actor.triangle_segment.size());
  EXPECT_EQ(actor.rest_positions.size(), topo.num_file_vertices);
  EXPECT_FALSE(topo.has_uvs());
  // Every edge is shared by exactly two triangles with opposite directions:
  // closed, consistently oriented parts.
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (const glm::uvec3& t : topo.file_triangles) {
    for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
  }
  for (const auto& [edge, count] : directed) {
    EXPECT_EQ(count, 1);
    EXPECT_EQ(directed.count({edge.second, edge.first}), 1u);
  }
  std::set<uint32_t> materials(actor.triangle_material.begin(), actor.triangle_material.end());
  EXPECT_EQ(materials, (std::set<uint32_t>{0, 1, 2}));
  // No degenerate triangles.
  for (const glm::uvec3& t : topo.file_triangles) {
    const glm::vec3 n = glm::cross(actor.rest_positions[t.y] - actor.rest_positions[t.x],
                                   actor.rest_positions[t.z] - actor.rest_positions[t.x]);
    EXPECT_GT(glm::length(n), 1e-9f);
  }
}

TEST(ActorTest, OutwardNormalsOnTheHead) {
  const Actor actor = MakeActor();
  // The highest vertex belongs to the top of the head; its smooth normal points up.
  size_t top = 0;
  for (size_t i = 0; i < actor.rest_positions.size(); ++i) {
    if (actor.rest_positions[i].y > actor.rest_positions[top].y) top = i;
  }
  const auto normals = scene::ComputeFileVertexNormals(actor.topology, actor.rest_positions);
  EXPECT_GT(normals[top].y, 0.9f);
  EXPECT_NEAR(actor.rest_positions[top].y, 1.75f, 0.08f);
}

TEST(ActorTest, PoseMovesVerticesSmoothlyAndStartsAtRest) {
  const Actor actor = MakeActor();
  const auto p0 = actor.Pose(0.0);
  ASSERT_EQ(p0.size(), actor.rest_positions.size());
  for (size_t i = 0; i < p0.size(); ++i) EXPECT_EQ(p0[i], actor.rest_positions[i]);
  const auto p1 = actor.Pose(0.5);
  const auto p_small = actor.Pose(1.0 / 60.0);
  float max_move = 0.0f, max_small = 0.0f;
  for (size_t i = 0; i < p0.size(); ++i) {
    max_move = std::max(max_move, glm::length(p1[i] - p0[i]));
    max_small = std::max(max_small, glm::length(p_small[i] - p0[i]));
  }
  EXPECT_GT(max_move, 0.1f);    // it dances
  EXPECT_LT(max_small, 0.05f);  // smoothly: < 5 cm in 1/60 s
  // Edge lengths are preserved (rigid parts).
  for (const glm::uvec3& t : actor.topology.file_triangles) {
    EXPECT_NEAR(glm::length(p1[t.y] - p1[t.x]), glm::length(p0[t.y] - p0[t.x]), 1e-4f);
  }
}

TEST(ActorTest, TessellationScalesTriangleCount) {
  ActorOptions fine;
  fine.segments = 48;
  EXPECT_GT(MakeActor(fine).topology.triangles.size(), 3 * MakeActor().topology.triangles.size());
}

}  // namespace
}  // namespace mvbrdf::synth
