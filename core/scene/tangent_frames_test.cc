#include "core/scene/tangent_frames.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/matrix_transform.hpp>

namespace mvbrdf::scene {
namespace {

constexpr float kTolerance = 1e-5f;

// A unit square in the z = 0 plane, UVs = (x, y) (or mirrored in u).
struct Square {
  std::vector<glm::uvec3> triangles{{0, 1, 2}, {0, 2, 3}};
  std::vector<glm::vec3> positions{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  std::vector<glm::vec3> normals{4, glm::vec3(0, 0, 1)};
  std::vector<glm::vec2> uvs{{0, 0}, {1, 0}, {1, 1}, {0, 1}};
};

void ExpectNear(const glm::vec3& a, const glm::vec3& b) {
  EXPECT_NEAR(a.x, b.x, kTolerance);
  EXPECT_NEAR(a.y, b.y, kTolerance);
  EXPECT_NEAR(a.z, b.z, kTolerance);
}

TEST(TangentFramesTest, TheTangentFollowsUAndTheBitangentV) {
  const Square s;
  for (const glm::vec4& t : VertexTangents(s.triangles, s.positions, s.normals, s.uvs)) {
    ExpectNear(glm::vec3(t), {1, 0, 0});
    EXPECT_EQ(t.w, 1.0f);
    const TangentFrame f = FrameAt(t, {0, 0, 1});
    ExpectNear(f.b, {0, 1, 0});
    // A normal map's +Y leans towards increasing v.
    ExpectNear(f.ToWorld(glm::normalize(glm::vec3(0, 1, 1))), glm::normalize(glm::vec3(0, 1, 1)));
  }
}

TEST(TangentFramesTest, MirroredUvsFlipTheHandedness) {
  Square s;
  for (glm::vec2& uv : s.uvs) uv.x = 1.0f - uv.x;
  for (const glm::vec4& t : VertexTangents(s.triangles, s.positions, s.normals, s.uvs)) {
    ExpectNear(glm::vec3(t), {-1, 0, 0});
    EXPECT_EQ(t.w, -1.0f);
    // B = w (n x t) is still the direction of increasing v.
    ExpectNear(FrameAt(t, {0, 0, 1}).b, {0, 1, 0});
  }
}

TEST(TangentFramesTest, AMovedMeshCarriesItsFrames) {
  // A tangent-space normal names the same surface direction after the mesh
  // moved: the frames turn with it (issue #18: one normal map, every frame).
  const Square rest;
  Square moved = rest;
  const glm::mat3 r(glm::rotate(glm::mat4(1.0f), 0.7f, glm::normalize(glm::vec3(1, 2, 3))));
  for (glm::vec3& p : moved.positions) p = r * p + glm::vec3(3, -1, 2);
  for (glm::vec3& n : moved.normals) n = r * n;
  const glm::vec3 m = glm::normalize(glm::vec3(0.3f, -0.2f, 1.0f));
  const auto t0 = VertexTangents(rest.triangles, rest.positions, rest.normals, rest.uvs);
  const auto t1 = VertexTangents(moved.triangles, moved.positions, moved.normals, moved.uvs);
  for (size_t i = 0; i < t0.size(); ++i) {
    ExpectNear(r * FrameAt(t0[i], rest.normals[i]).ToWorld(m), FrameAt(t1[i], moved.normals[i]).ToWorld(m));
  }
}

TEST(TangentFramesTest, DegenerateUvsGiveSomeOrthogonalTangent) {
  Square s;
  for (glm::vec2& uv : s.uvs) uv = {0.5f, 0.5f};
  for (const glm::vec4& t : VertexTangents(s.triangles, s.positions, s.normals, s.uvs)) {
    EXPECT_NEAR(glm::length(glm::vec3(t)), 1.0f, kTolerance);
    EXPECT_NEAR(glm::dot(glm::vec3(t), glm::vec3(0, 0, 1)), 0.0f, kTolerance);
  }
  // No UVs at all: the same.
  for (const glm::vec4& t : VertexTangents(s.triangles, s.positions, s.normals, {})) {
    EXPECT_NEAR(glm::dot(glm::vec3(t), glm::vec3(0, 0, 1)), 0.0f, kTolerance);
  }
}

TEST(TangentFramesTest, FramesAreOrthonormal) {
  const TangentFrame f = FrameAt({0.8f, 0.1f, 0.5f, -1.0f}, glm::normalize(glm::vec3(0.2f, 0.1f, 1.0f)));
  EXPECT_NEAR(glm::dot(f.t, f.n), 0.0f, kTolerance);
  EXPECT_NEAR(glm::dot(f.b, f.n), 0.0f, kTolerance);
  EXPECT_NEAR(glm::dot(f.t, f.b), 0.0f, kTolerance);
  const glm::vec3 d = glm::normalize(glm::vec3(0.4f, -0.3f, 0.8f));
  ExpectNear(f.ToWorld(f.ToTangent(d)), d);
}

}  // namespace
}  // namespace mvbrdf::scene
