#include "core/synth/subject.h"

#include <cmath>
#include <utility>

#include <glm/gtc/matrix_transform.hpp>

#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"
#include "core/scene/mesh_loader.h"
#include "core/scene/video_source.h"
#include "core/synth/actor.h"

namespace mvbrdf::synth {
namespace {

SubjectBounds Bounds(const scene::FramePositions& p) {
  SubjectBounds b{p.front(), p.front()};
  for (const glm::vec3& v : p) {
    b.min = glm::min(b.min, v);
    b.max = glm::max(b.max, v);
  }
  return b;
}

}  // namespace

Subject MakeActorSubject(int segments, double fps) {
  ActorOptions options;
  options.segments = segments;
  auto actor = std::make_shared<Actor>(MakeActor(options));
  Subject s;
  s.preset = "actor";
  s.topology = actor->topology;
  s.rest_positions = actor->rest_positions;
  s.pose = [actor, fps](int t) -> absl::StatusOr<scene::FramePositions> { return actor->Pose(t / fps); };
  s.materials = StudioMaterials();
  s.triangle_material = actor->triangle_material;
  s.segment_names = actor->segment_names;
  s.triangle_segment = actor->triangle_segment;
  return s;
}

absl::StatusOr<Subject> MakeSpotSubject(const std::filesystem::path& data_dir) {
  const auto mesh_file = data_dir / "spot" / "spot_triangulated.obj";
  const auto texture_file = data_dir / "spot" / "spot_texture.png";
  MVBRDF_ASSIGN_OR_RETURN(scene::LoadedMesh mesh, scene::LoadMesh(mesh_file, "spot mesh"));
  Subject s;
  s.preset = "spot";
  MVBRDF_ASSIGN_OR_RETURN(s.kd_texture, scene::ReadLinearRgbImage(texture_file, /*srgb=*/true));
  s.kd_texture_file = texture_file;
  s.topology = std::move(mesh.topology);
  s.rest_positions = std::move(mesh.positions);
  const SubjectBounds b = Bounds(s.rest_positions);
  const glm::vec3 axis_point = 0.5f * (b.min + b.max);
  const scene::FramePositions rest = s.rest_positions;
  s.pose = [rest, axis_point](int t) -> absl::StatusOr<scene::FramePositions> {
    const float angle = 2.0f * 3.14159265f * static_cast<float>(t) / 120.0f;
    const glm::mat4 m = glm::translate(glm::mat4(1.0f), axis_point) *
                        glm::rotate(glm::mat4(1.0f), angle, glm::vec3(0, 1, 0)) *
                        glm::translate(glm::mat4(1.0f), -axis_point);
    scene::FramePositions out(rest.size());
    for (size_t i = 0; i < rest.size(); ++i) out[i] = glm::vec3(m * glm::vec4(rest[i], 1.0f));
    return out;
  };
  StudioMaterial spot;
  spot.name = "spot";
  spot.seed_srgb8 = {200, 200, 200};
  spot.kd = {glm::vec3(0.5f), 0.0f, 1.0f, glm::vec3(0.0f)};
  spot.ks = glm::vec3(0.1f);
  spot.ke = glm::vec3(12.0f);
  s.materials = {spot};
  s.triangle_material.assign(s.topology.triangles.size(), 0);
  return s;
}

Subject MakeSphereSubject() {
  constexpr int kRings = 24, kSegments = 48;
  constexpr float kRadius = 0.5f;
  const glm::vec3 center(0.0f, 1.0f, 0.0f);
  Subject s;
  s.preset = "sphere";
  scene::FramePositions& p = s.rest_positions;
  p.push_back(center + glm::vec3(0.0f, kRadius, 0.0f));  // north pole
  for (int i = 1; i < kRings; ++i) {
    const float theta = 3.14159265f * static_cast<float>(i) / kRings;
    for (int j = 0; j < kSegments; ++j) {
      const float phi = 2.0f * 3.14159265f * static_cast<float>(j) / kSegments;
      p.push_back(center + kRadius * glm::vec3(std::sin(theta) * std::cos(phi), std::cos(theta),
                                               std::sin(theta) * std::sin(phi)));
    }
  }
  const uint32_t south = static_cast<uint32_t>(p.size());
  p.push_back(center - glm::vec3(0.0f, kRadius, 0.0f));
  const auto ring = [](int i, int j) { return static_cast<uint32_t>(1 + (i - 1) * kSegments + (j % kSegments)); };
  std::vector<glm::uvec3>& tris = s.topology.file_triangles;
  for (int j = 0; j < kSegments; ++j) tris.emplace_back(0, ring(1, j + 1), ring(1, j));
  for (int i = 1; i + 1 < kRings; ++i) {
    for (int j = 0; j < kSegments; ++j) {
      tris.emplace_back(ring(i, j), ring(i, j + 1), ring(i + 1, j + 1));
      tris.emplace_back(ring(i, j), ring(i + 1, j + 1), ring(i + 1, j));
    }
  }
  for (int j = 0; j < kSegments; ++j) tris.emplace_back(south, ring(kRings - 1, j), ring(kRings - 1, j + 1));
  for (glm::uvec3& t : tris) {  // counter-clockwise seen from outside
    const glm::vec3 a = p[t.x], b = p[t.y], c = p[t.z];
    if (glm::dot(glm::cross(b - a, c - a), (a + b + c) / 3.0f - center) < 0.0f) std::swap(t.y, t.z);
  }
  const uint32_t n = static_cast<uint32_t>(p.size());
  s.topology.num_file_vertices = n;
  s.topology.triangles = tris;
  s.topology.render_to_file_vertex.resize(n);
  for (uint32_t i = 0; i < n; ++i) s.topology.render_to_file_vertex[i] = i;
  const scene::FramePositions rest = p;
  s.pose = [rest](int) -> absl::StatusOr<scene::FramePositions> { return rest; };
  StudioMaterial m;
  m.name = "sphere";
  m.kd = {glm::vec3(0.55f, 0.35f, 0.25f), 0.0f, 1.0f, glm::vec3(0.0f)};
  m.seed_srgb8 = {196, 160, 137};  // sRGB of kd
  m.ks = glm::vec3(0.2f);
  m.ke = glm::vec3(15.0f);
  s.materials = {m};
  s.triangle_material.assign(tris.size(), 0);
  return s;
}

absl::StatusOr<Subject> MakeSambaSubject(const std::filesystem::path& data_dir) {
  const std::string pattern = (data_dir / "samba" / "mesh_%04d.obj").string();
  MVBRDF_ASSIGN_OR_RETURN(scene::LoadedMesh mesh, scene::LoadMesh(FormatFramePattern(pattern, 0), "samba mesh"));
  Subject s;
  s.preset = "samba";
  s.max_frames = 175;
  s.topology = std::move(mesh.topology);
  s.rest_positions = std::move(mesh.positions);
  const scene::MeshTopology topology = s.topology;
  s.pose = [pattern, topology](int t) -> absl::StatusOr<scene::FramePositions> {
    return scene::LoadFramePositions(FormatFramePattern(pattern, t), topology, "samba mesh");
  };
  s.materials = StudioMaterials();
  const SubjectBounds b = Bounds(s.rest_positions);
  const float h = b.max.y - b.min.y;
  s.triangle_material.resize(s.topology.file_triangles.size());
  for (size_t i = 0; i < s.topology.file_triangles.size(); ++i) {
    const glm::uvec3 t = s.topology.file_triangles[i];
    const glm::vec3 c = (s.rest_positions[t.x] + s.rest_positions[t.y] + s.rest_positions[t.z]) / 3.0f;
    const float rel = (c.y - b.min.y) / h;
    s.triangle_material[i] = rel > 0.945f ? 2u : rel > 0.85f ? 1u : 0u;
  }
  return s;
}

}  // namespace mvbrdf::synth
