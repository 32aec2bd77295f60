// Loads mesh files (OBJ, PLY, glTF) with assimp into MeshTopology plus the
// file-vertex positions of that file.
//
// File vertices are found by welding face corners with bit-identical positions
// in the first file loaded (the rest pose); render vertices by welding corners
// with identical (position, UV). Triangles keep file order (assimp meshes in
// scene order, faces in order). A later frame's file must have the same face
// count and its welded corners must agree, else the topology differs.
//
// Assimp runs in a forked child process (10-120 ms per file, the fork in
// proportion to the caller's memory): it crashes on
// some malformed files, and a crash there fails the load with
// INVALID_ARGUMENT instead of ending the calling server or worker; so does an
// importer running longer than 5 s + 1 s per MiB of file or growing the
// process by more than 2 GiB + 64 x the file size. A PLY header declaring more
// elements than the file holds is rejected before assimp sees it. Safe to call
// from any thread; the child only runs the importer and leaves by _exit.
#ifndef MVBRDF_CORE_SCENE_MESH_LOADER_H_
#define MVBRDF_CORE_SCENE_MESH_LOADER_H_

#include <filesystem>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/scene/mesh.h"

namespace mvbrdf::scene {

struct LoadedMesh {
  MeshTopology topology;
  FramePositions positions;  // per file vertex
};

// Loads the rest-pose mesh. `field` names the scene field in errors, e.g.
// "scene.mesh.path". Errors: missing file (NOT_FOUND), no faces, non-finite
// vertices, UVs more than kMaxUvExcursion outside [0,1]^2 (INVALID_ARGUMENT
// naming the file and vertex). UVs slightly outside are clamped and listed in
// topology.clamped_uv_vertices; zero-area triangles are listed in
// topology.zero_area_triangles; neither is an error.
//
// File and render vertices are numbered in order of first use by the
// triangles. WriteObj of a topology numbered that way (any LoadMesh result)
// reads back identically; other numberings read back renumbered, and file
// vertices with bit-identical positions read back welded.
//
// flip_winding (scene.mesh.flipWinding) reverses every triangle's corner
// order as the file is read, and so its facing: for a mesh whose triangles
// face inwards.
absl::StatusOr<LoadedMesh> LoadMesh(const std::filesystem::path& file, absl::string_view field,
                                    bool flip_winding = false);

// Loads the file-vertex positions of another frame of the same mesh; fails
// with INVALID_ARGUMENT when its topology differs from `topology` or a vertex
// is not finite, NOT_FOUND when the file is missing. Positions are read as
// LoadMesh reads them, so the rest pose's file gives the same floats: in this
// process by ReadPlainObjCorners (obj_reader.h) when topology.plain_obj and
// the file is a plain OBJ, else by assimp. `flip_winding` as the rest pose
// was loaded.
absl::StatusOr<FramePositions> LoadFramePositions(const std::filesystem::path& file, const MeshTopology& topology,
                                                  absl::string_view field, bool flip_winding = false);

// Six times the signed volume the triangles enclose (sum of det(a, b, c)),
// and whether the mesh is closed and consistently oriented: every edge (over
// file vertices) is used once in each direction. Negative for a closed mesh
// whose triangles face inwards. Zero-area triangles count like the others.
struct MeshOrientation {
  bool closed = false;
  double signed_volume = 0.0;
  double diagonal_cubed = 0.0;  // the positions' bounding-box diagonal cubed, for scale
};
MeshOrientation ComputeMeshOrientation(const MeshTopology& topology, const FramePositions& positions);

// Sets the importer's time limit (seconds + seconds_per_mib * file MiB;
// default 5 + 1). For the fuzzer, which meets hangs often; any thread.
void SetImportTimeLimitForTesting(double seconds, double seconds_per_mib);
// Called in the importer child before the import, with the attempt (0, then 1
// when the first child was found blocked); nullptr: none. Tests only.
void SetImportChildHookForTesting(void (*hook)(int attempt));

// The triangles' corner positions assimp reads from `file`, in this process
// (no child): for tests and the fuzzer that hold the plain-OBJ reader
// (obj_reader.h) to assimp on inputs that reader calls plain.
absl::StatusOr<std::vector<glm::vec3>> ImportCornerPositionsHereForTesting(const std::filesystem::path& file);

// Writes a mesh as Wavefront OBJ (v, optional vt, f lines), file vertices as
// `v` lines in order, so that LoadMesh reads back the same topology.
absl::Status WriteObj(const std::filesystem::path& file, const MeshTopology& topology, const FramePositions& positions);

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_MESH_LOADER_H_
