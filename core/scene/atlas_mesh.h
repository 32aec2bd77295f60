// atlas/mesh.obj in the input's vertex order (issue #20 item 3), so that a
// tracked motion can be re-applied by vertex index.
#ifndef MVBRDF_CORE_SCENE_ATLAS_MESH_H_
#define MVBRDF_CORE_SCENE_ATLAS_MESH_H_

#include <cstdint>
#include <filesystem>
#include <vector>

#include "absl/status/status.h"
#include "core/scene/mesh.h"
#include "core/scene/sequence.h"

namespace mvbrdf::scene {

// The vertex numbering of the input mesh file: for an OBJ, its `v` lines in
// file order, every one, used or not, each matched to the file vertex with its
// position's bits (within 2 ulp: assimp's parser is not correctly rounded); for other formats, or an
// OBJ whose file vertices cannot all be matched to `v` lines (homogeneous
// coordinates), the file vertices of LoadMesh (order of first use).
struct InputVertexOrder {
  std::vector<glm::vec3> positions;            // per input vertex
  std::vector<uint32_t> input_of_file_vertex;  // per file vertex (LoadMesh's numbering): its input vertex
  bool from_file = false;                      // positions are the file's own `v` lines
};
InputVertexOrder InputVertexOrderOf(const std::filesystem::path& mesh_file, const FramePositions& rest_positions);

// Writes DIR/mesh.obj and DIR/seams.txt for a mesh with atlas UVs
// (`atlas_topology` over the file vertices of `sequence`'s rest pose):
// mesh.obj has one `v` line per input vertex in the input file's order (rest
// pose: frame 0's mesh file), one `vt` line per atlas vertex (render vertex:
// a vertex on a chart seam has one per chart), faces `f v/vt` in the input's
// triangle order (corners as loaded: after flip_winding). seams.txt: a
// comment line, then per atlas vertex (vt line i + 1) its input vertex (v
// line, 0-based). Frame t's positions are frame t's mesh file's `v` lines.
absl::Status WriteAtlasMesh(const std::filesystem::path& dir, const MeshTopology& atlas_topology,
                            const Sequence& sequence);

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_ATLAS_MESH_H_
