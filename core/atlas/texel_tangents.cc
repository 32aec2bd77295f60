#include "core/atlas/texel_tangents.h"

#include <cmath>

#include "core/scene/tangent_frames.h"

namespace mvbrdf::atlas {

TexelTangents::TexelTangents(const Atlas& atlas) : atlas_(atlas) {
  const size_t n = static_cast<size_t>(atlas.size) * static_cast<size_t>(atlas.size);
  triangle_.assign(n, -1);
  barycentric_.assign(n, glm::vec3(0.0f));
  if (atlas.triangle_id.empty() || !atlas.topology.has_uvs()) return;
  const auto& uvs = atlas.topology.uvs;
  for (int row = 0; row < atlas.size; ++row) {
    for (int column = 0; column < atlas.size; ++column) {
      const int32_t t = atlas.triangle_id.at<int32_t>(row, column);
      if (t < 0 || static_cast<size_t>(t) >= atlas.topology.triangles.size()) continue;
      const glm::uvec3& tri = atlas.topology.triangles[static_cast<size_t>(t)];
      // The texel centre in UV space (core/atlas/atlas.h's convention).
      const glm::dvec2 p((column + 0.5) / atlas.size, 1.0 - (row + 0.5) / atlas.size);
      const glm::dvec2 a(uvs[tri.x]), b(uvs[tri.y]), c(uvs[tri.z]);
      const auto cross = [](const glm::dvec2& u, const glm::dvec2& v) { return u.x * v.y - u.y * v.x; };
      const double area = cross(b - a, c - a);
      if (!(std::fabs(area) > 0.0)) continue;
      const size_t i = static_cast<size_t>(row) * static_cast<size_t>(atlas.size) + static_cast<size_t>(column);
      triangle_[i] = t;
      barycentric_[i] = glm::vec3(glm::dvec3(cross(b - p, c - p), cross(c - p, a - p), cross(a - p, b - p)) / area);
    }
  }
}

std::vector<glm::vec4> TexelTangents::Compute(const scene::FramePositions& file_positions) const {
  const scene::MeshTopology& topology = atlas_.topology;
  const std::vector<glm::vec3> positions = scene::ToRenderVertices(topology, file_positions);
  const std::vector<glm::vec3> normals =
      scene::ToRenderVertices(topology, scene::ComputeFileVertexNormals(topology, file_positions));
  const std::vector<glm::vec4> vertex = scene::VertexTangents(topology.triangles, positions, normals, topology.uvs);
  std::vector<glm::vec4> texel(triangle_.size(), glm::vec4(0.0f));
  for (size_t i = 0; i < triangle_.size(); ++i) {
    if (triangle_[i] < 0) continue;
    const glm::uvec3& tri = topology.triangles[static_cast<size_t>(triangle_[i])];
    const glm::vec3& w = barycentric_[i];
    texel[i] = w.x * vertex[tri.x] + w.y * vertex[tri.y] + w.z * vertex[tri.z];
  }
  return texel;
}

}  // namespace mvbrdf::atlas
