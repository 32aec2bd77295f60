// libFuzzer target: the mesh loaders (core/scene/mesh_loader.h) on every
// supported format. The first byte selects the file extension (assimp picks
// its importer by it): 0 .obj, 1 .ply, 2 .gltf, 3 .glb; the rest of the input
// is the file.
//
// Assimp runs in a child process (mesh_loader.cc), so its own crashes and
// hangs come back as errors; what is checked here is our code around it.
// For each input: LoadMesh must return a Status or a consistent topology
// (indices in range, finite positions); LoadFramePositions of the same file
// against its own topology must give the same positions; the file read as a
// later frame of a fixed pyramid must fail or give 5 finite positions; and a
// loaded mesh written back with WriteObj must load again with the same
// triangles and positions. An OBJ file the in-process reader (obj_reader.h)
// calls plain must read the same through assimp: LoadMesh then marks it
// plain, or fails on a check of ours (a non-finite position, a UV far outside
// [0,1]), never in assimp.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "core/scene/mesh_loader.h"
#include "core/scene/obj_reader.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

using mvbrdf::fuzz::Require;
using mvbrdf::scene::FramePositions;
using mvbrdf::scene::LoadedMesh;
using mvbrdf::scene::MeshTopology;

constexpr const char* kExtensions[] = {".obj", ".ply", ".gltf", ".glb"};

const MeshTopology& Pyramid() {
  static const MeshTopology* topology = [] {
    // Inputs are a few KB: an import taking 1 s is a hang, and the default
    // limit (5 s) would make each such input cost 5 s.
    mvbrdf::scene::SetImportTimeLimitForTesting(1.0, 0.0);
    const std::filesystem::path file = mvbrdf::fuzz::ScratchDir() / "pyramid.obj";
    const std::string obj =
        "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nv 0.5 1 0.5\n"
        "f 1 2 3\nf 1 3 4\nf 1 5 2\nf 2 5 3\nf 3 5 4\nf 4 5 1\n";
    mvbrdf::fuzz::WriteBytes(file, reinterpret_cast<const uint8_t*>(obj.data()), obj.size());
    absl::StatusOr<LoadedMesh> mesh = mvbrdf::scene::LoadMesh(file, "pyramid");
    Require(mesh.ok(), "mesh_loader_fuzz: the pyramid does not load");
    return new MeshTopology(std::move(mesh->topology));
  }();
  return *topology;
}

bool AllFinite(const FramePositions& positions) {
  for (const glm::vec3& p : positions) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return false;
  }
  return true;
}

// assimp's OBJ number parser (fast_atof) does not read subnormal floats back
// exactly (9.18354962e-41 comes back as another value), so positions written
// with "%.9g" round-trip only when none is subnormal. Real meshes hold none.
bool AnySubnormal(const FramePositions& positions) {
  for (const glm::vec3& p : positions) {
    for (int i = 0; i < 3; ++i) {
      if (std::fpclassify(p[i]) == FP_SUBNORMAL) return true;
    }
  }
  return false;
}

void CheckTopology(const LoadedMesh& mesh) {
  const MeshTopology& t = mesh.topology;
  Require(!t.triangles.empty(), "mesh_loader_fuzz: a loaded mesh without triangles");
  Require(t.triangles.size() == t.file_triangles.size(), "mesh_loader_fuzz: triangle lists differ in length");
  Require(t.num_file_vertices == mesh.positions.size(), "mesh_loader_fuzz: num_file_vertices != positions");
  Require(AllFinite(mesh.positions), "mesh_loader_fuzz: a non-finite position was accepted");
  Require(!t.has_uvs() || t.uvs.size() == t.render_to_file_vertex.size(), "mesh_loader_fuzz: uvs != render vertices");
  for (size_t i = 0; i < t.triangles.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      Require(t.file_triangles[i][k] < t.num_file_vertices, "mesh_loader_fuzz: file index out of range");
      Require(t.triangles[i][k] < t.num_render_vertices(), "mesh_loader_fuzz: render index out of range");
      Require(t.render_to_file_vertex[t.triangles[i][k]] == t.file_triangles[i][k],
              "mesh_loader_fuzz: render vertex maps to another file vertex");
    }
  }
  for (const glm::vec2& uv : t.uvs) {
    Require(uv.x >= 0.0f && uv.x <= 1.0f && uv.y >= 0.0f && uv.y <= 1.0f, "mesh_loader_fuzz: a UV outside [0,1]");
  }
  for (uint32_t v : t.clamped_uv_vertices) Require(v < t.num_render_vertices(), "mesh_loader_fuzz: clamped index");
  for (uint32_t z : t.zero_area_triangles) Require(z < t.triangles.size(), "mesh_loader_fuzz: zero-area index");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const MeshTopology& pyramid = Pyramid();
  const std::filesystem::path file = mvbrdf::fuzz::ScratchDir() / (std::string("input") + kExtensions[data[0] % 4]);
  mvbrdf::fuzz::WriteBytes(file, data + 1, size - 1);

  absl::StatusOr<LoadedMesh> mesh = mvbrdf::scene::LoadMesh(file, "mesh");
  mvbrdf::fuzz::Trace("LoadMesh", mesh.status());
  if (kExtensions[data[0] % 4] == std::string_view(".obj") &&
      mvbrdf::scene::ReadPlainObjCorners(std::string_view(reinterpret_cast<const char*>(data + 1), size - 1))) {
    const std::string why = mesh.ok() ? std::string() : std::string(mesh.status().message());
    Require(mesh.ok() ? mesh->topology.plain_obj
                      : why.find("non-finite") != std::string::npos || why.find("texture coordinate") != std::string::npos,
            "mesh_loader_fuzz: the plain-OBJ reader and assimp disagree");
  }
  // A file the importer crashed or hung on (seconds each) is not read again.
  if (!mesh.ok() && mesh.status().message().find("importer (assimp)") != std::string::npos) return 0;

  absl::StatusOr<FramePositions> frame = mvbrdf::scene::LoadFramePositions(file, pyramid, "frame");
  mvbrdf::fuzz::Trace("LoadFramePositions (pyramid)", frame.status());
  if (frame.ok()) {
    Require(frame->size() == pyramid.num_file_vertices, "mesh_loader_fuzz: frame positions of the wrong count");
    Require(AllFinite(*frame), "mesh_loader_fuzz: a non-finite frame position was accepted");
  }
  if (!mesh.ok()) {
    Require(!mesh.status().message().empty(), "mesh_loader_fuzz: an error without a message");
    return 0;
  }
  CheckTopology(*mesh);
  absl::StatusOr<FramePositions> same = mvbrdf::scene::LoadFramePositions(file, mesh->topology, "mesh");
  Require(same.ok(), "mesh_loader_fuzz: LoadFramePositions rejects the file LoadMesh accepted");
  Require(*same == mesh->positions, "mesh_loader_fuzz: LoadFramePositions and LoadMesh disagree");

  const std::filesystem::path obj = mvbrdf::fuzz::ScratchDir() / "written.obj";
  Require(mvbrdf::scene::WriteObj(obj, mesh->topology, mesh->positions).ok(), "mesh_loader_fuzz: WriteObj failed");
  absl::StatusOr<LoadedMesh> back = mvbrdf::scene::LoadMesh(obj, "written");
  Require(back.ok(), "mesh_loader_fuzz: a written mesh does not load");
  Require(back->topology.file_triangles == mesh->topology.file_triangles &&
              (back->positions == mesh->positions || AnySubnormal(mesh->positions)),
          "mesh_loader_fuzz: a written mesh loads with other triangles or positions");
  return 0;
}
