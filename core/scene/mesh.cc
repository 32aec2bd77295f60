#include "core/scene/mesh.h"

namespace mvbrdf::scene {

std::vector<glm::vec3> ToRenderVertices(const MeshTopology& topology, const FramePositions& file_positions) {
  std::vector<glm::vec3> out(topology.num_render_vertices());
  for (size_t i = 0; i < out.size(); ++i) out[i] = file_positions[topology.render_to_file_vertex[i]];
  return out;
}

std::vector<glm::vec3> ComputeFileVertexNormals(const MeshTopology& topology, const FramePositions& file_positions) {
  std::vector<glm::vec3> normals(file_positions.size(), glm::vec3(0.0f));
  for (const glm::uvec3& t : topology.file_triangles) {
    const glm::vec3& a = file_positions[t.x];
    const glm::vec3& b = file_positions[t.y];
    const glm::vec3& c = file_positions[t.z];
    // Cross product length is twice the area: area weighting for free.
    const glm::vec3 n = glm::cross(b - a, c - a);
    normals[t.x] += n;
    normals[t.y] += n;
    normals[t.z] += n;
  }
  for (glm::vec3& n : normals) {
    const float len = glm::length(n);
    n = len > 0.0f ? n / len : glm::vec3(0.0f);
  }
  return normals;
}

}  // namespace mvbrdf::scene
