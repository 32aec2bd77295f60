#include "core/scene/atlas_mesh.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <unordered_map>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"

namespace mvbrdf::scene {
namespace {

namespace fs = std::filesystem;

uint64_t Hash(const glm::vec3& p) {
  uint32_t b[3];
  std::memcpy(b, &p, sizeof(b));
  return (uint64_t{b[0]} * 0x9E3779B97F4A7C15ull) ^ (uint64_t{b[1]} * 0xC2B2AE3D27D4EB4Full) ^ b[2];
}

bool SameBits(const glm::vec3& a, const glm::vec3& b) { return std::memcmp(&a, &b, sizeof(glm::vec3)) == 0; }

// The `v` lines of an OBJ text; false when one is not three numbers (a
// fourth, homogeneous w, changes the position assimp computes).
bool ObjVertices(const std::string& text, std::vector<glm::vec3>* out) {
  size_t i = 0;
  while (i < text.size()) {
    size_t end = text.find('\n', i);
    if (end == std::string::npos) end = text.size();
    size_t k = i;
    while (k < end && (text[k] == ' ' || text[k] == '\t')) ++k;
    if (k + 1 < end && text[k] == 'v' && (text[k + 1] == ' ' || text[k + 1] == '\t')) {
      const std::string line = text.substr(k + 2, end - k - 2);
      const char* c = line.c_str();
      float xyz[7];
      int n = 0;
      while (*c != '\0' && *c != '#') {
        while (*c == ' ' || *c == '\t' || *c == '\r') ++c;
        if (*c == '\0' || *c == '#') break;
        if (n == 7) return false;
        char* next = nullptr;
        xyz[n++] = std::strtof(c, &next);
        if (next == c) return false;
        c = next;
      }
      // x y z, or x y z r g b (a colour); x y z w is homogeneous: not matched.
      if (n != 3 && n != 6) return false;
      out->emplace_back(xyz[0], xyz[1], xyz[2]);
    }
    i = end + 1;
  }
  return true;
}

}  // namespace

InputVertexOrder InputVertexOrderOf(const fs::path& mesh_file, const FramePositions& rest_positions) {
  InputVertexOrder identity;
  identity.positions = rest_positions;
  identity.input_of_file_vertex.resize(rest_positions.size());
  for (uint32_t i = 0; i < rest_positions.size(); ++i) identity.input_of_file_vertex[i] = i;
  if (absl::AsciiStrToLower(mesh_file.extension().string()) != ".obj") return identity;
  absl::StatusOr<std::string> text = ReadFileToString(mesh_file);
  InputVertexOrder order;
  if (!text.ok() || !ObjVertices(*text, &order.positions)) return identity;
  // Each file vertex is the first `v` line with its position's bits (LoadMesh
  // welds bit-identical positions).
  std::unordered_multimap<uint64_t, uint32_t> file_vertex_of;
  for (uint32_t f = 0; f < rest_positions.size(); ++f) file_vertex_of.emplace(Hash(rest_positions[f]), f);
  constexpr uint32_t kNone = ~0u;
  order.input_of_file_vertex.assign(rest_positions.size(), kNone);
  const auto match = [&](uint32_t i, const glm::vec3& p) {
    auto [lo, hi] = file_vertex_of.equal_range(Hash(p));
    bool found = false;
    for (auto it = lo; it != hi; ++it) {
      if (!SameBits(rest_positions[it->second], p)) continue;
      found = true;
      if (order.input_of_file_vertex[it->second] == kNone) order.input_of_file_vertex[it->second] = i;
    }
    return found;
  };
  for (uint32_t i = 0; i < order.positions.size(); ++i) {
    const glm::vec3 p = order.positions[i];
    if (match(i, p)) continue;
    // assimp's OBJ parser (fast_atof) is not always correctly rounded: the
    // same text may be a float or two away from strtof's.
    bool found = false;
    for (int dx = -2; dx <= 2 && !found; ++dx) {
      for (int dy = -2; dy <= 2 && !found; ++dy) {
        for (int dz = -2; dz <= 2 && !found; ++dz) {
          const auto step = [](float v, int d) {
            for (; d > 0; --d) v = std::nextafter(v, INFINITY);
            for (; d < 0; ++d) v = std::nextafter(v, -INFINITY);
            return v;
          };
          const glm::vec3 q(step(p.x, dx), step(p.y, dy), step(p.z, dz));
          found = match(i, q);  // positions stays the file's value, correctly rounded
        }
      }
    }
  }
  for (uint32_t v : order.input_of_file_vertex) {
    if (v == kNone) return identity;
  }
  order.from_file = true;
  return order;
}

absl::Status WriteAtlasMesh(const fs::path& dir, const MeshTopology& topology, const Sequence& sequence) {
  const fs::path rest_file =
      ResolvePath(sequence.scene_dir, FormatFramePattern(sequence.scene.mesh().path(), sequence.AbsoluteFrame(0)));
  const InputVertexOrder order = InputVertexOrderOf(rest_file, sequence.rest_positions);
  if (order.input_of_file_vertex.size() != topology.num_file_vertices) {
    return absl::InvalidArgumentError(absl::StrCat(dir.string(), ": ", order.input_of_file_vertex.size(),
                                                   " rest positions for an atlas mesh of ", topology.num_file_vertices,
                                                   " file vertices"));
  }
  std::string obj, seams;
  obj.reserve(order.positions.size() * 40 + topology.uvs.size() * 28 + topology.triangles.size() * 40);
  obj += order.from_file ? "# written by mvbrdf: v lines are the input mesh's vertices in its file order (rest pose), "
                           "vt lines the atlas vertices; seams.txt gives each atlas vertex's v\n"
                         : "# written by mvbrdf: v lines are the mesh's vertices in order of first use by a face "
                           "(the input is not an OBJ), vt lines the atlas vertices; seams.txt gives each atlas "
                           "vertex's v\n";
  char line[128];
  for (const glm::vec3& p : order.positions) {
    std::snprintf(line, sizeof(line), "v %.9g %.9g %.9g\n", p.x, p.y, p.z);  // %.9g round-trips a float
    obj += line;
  }
  for (const glm::vec2& uv : topology.uvs) {
    std::snprintf(line, sizeof(line), "vt %.9g %.9g\n", uv.x, uv.y);
    obj += line;
  }
  for (size_t t = 0; t < topology.file_triangles.size(); ++t) {
    const glm::uvec3& f = topology.file_triangles[t];
    const uint32_t a = order.input_of_file_vertex[f.x] + 1, b = order.input_of_file_vertex[f.y] + 1,
                   c = order.input_of_file_vertex[f.z] + 1;
    if (topology.has_uvs()) {
      const glm::uvec3& r = topology.triangles[t];
      std::snprintf(line, sizeof(line), "f %u/%u %u/%u %u/%u\n", a, r.x + 1, b, r.y + 1, c, r.z + 1);
    } else {
      std::snprintf(line, sizeof(line), "f %u %u %u\n", a, b, c);
    }
    obj += line;
  }
  seams = "# per atlas vertex (vt line i + 1 of mesh.obj, i from 0): its input vertex (v line, 0-based)\n";
  for (size_t r = 0; r < topology.render_to_file_vertex.size(); ++r) {
    absl::StrAppend(&seams, order.input_of_file_vertex[topology.render_to_file_vertex[r]], "\n");
  }
  MVBRDF_RETURN_IF_ERROR(WriteStringToFile(dir / "mesh.obj", obj));
  return WriteStringToFile(dir / "seams.txt", seams);
}

}  // namespace mvbrdf::scene
