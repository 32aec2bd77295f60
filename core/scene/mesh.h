// The tracked mesh of a sequence: fixed connectivity, one pose per frame.
//
// Two kinds of vertex:
// - file vertices: the distinct positions of the mesh file (what moves from
//   frame to frame; per-frame files give one position per file vertex);
// - render vertices: what the GPU draws; a file vertex on a UV seam becomes
//   several render vertices with the same position and different UVs.
// `render_to_file_vertex` maps each render vertex to its file vertex, so that a
// frame's file positions apply to the right render vertices.
#ifndef MVBRDF_CORE_SCENE_MESH_H_
#define MVBRDF_CORE_SCENE_MESH_H_

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace mvbrdf::scene {

// How far outside [0,1]^2 a texture coordinate may lie and still be clamped
// into it rather than rejected (in UV units, i.e. a fraction of the atlas).
inline constexpr float kMaxUvExcursion = 0.1f;

struct MeshTopology {
  // Triangles over render vertices, in file order (counter-clockwise seen
  // from outside).
  std::vector<glm::uvec3> triangles;
  // The same triangles over file vertices.
  std::vector<glm::uvec3> file_triangles;
  // Per render vertex: its file vertex.
  std::vector<uint32_t> render_to_file_vertex;
  // Per render vertex texture coordinates in [0,1]^2 (v up, OpenGL style);
  // empty when the mesh has no UVs (an atlas is built later).
  std::vector<glm::vec2> uvs;
  // Render vertices whose UVs lay slightly outside [0,1]^2 in the file (by
  // more than a rounding error, at most kMaxUvExcursion; e.g. 4 of Spot's) and
  // were clamped into it. Farther outside is an error (tiled UVs).
  std::vector<uint32_t> clamped_uv_vertices;
  uint32_t num_file_vertices = 0;
  // Indices of triangles with zero area in the rest pose (frame 0); they are
  // kept in `triangles` (indices stay stable) but excluded from resampling
  // and fitting.
  std::vector<uint32_t> zero_area_triangles;
  // The rest pose is an OBJ file that ReadPlainObjCorners (obj_reader.h)
  // reads as assimp does: later frames' OBJ files are read by it in-process
  // where it can, the others by assimp (mesh_loader.h).
  bool plain_obj = false;

  size_t num_render_vertices() const { return render_to_file_vertex.size(); }
  bool has_uvs() const { return !uvs.empty(); }
};

// File-vertex positions in world units for one frame.
using FramePositions = std::vector<glm::vec3>;

// Per render vertex positions for one frame.
std::vector<glm::vec3> ToRenderVertices(const MeshTopology& topology, const FramePositions& file_positions);

// Area-weighted smooth vertex normals per file vertex (so UV seams do not show
// as creases), unit length; (0,0,0) for a vertex with only zero-area triangles.
std::vector<glm::vec3> ComputeFileVertexNormals(const MeshTopology& topology, const FramePositions& file_positions);

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_MESH_H_
