#include "core/resample/resample_test_util.h"

#include <algorithm>
#include <cmath>

namespace mvbrdf::resample::testing {

QuadScene MakeQuadScene(const std::vector<Quad>& quads, int atlas_size) {
  QuadScene scene;
  scene.quads = quads;
  scene::MeshTopology& topo = scene.atlas.topology;
  for (const Quad& q : quads) {
    const uint32_t first = static_cast<uint32_t>(scene.positions.size());
    const double st[4][2] = {{0, 0}, {1, 0}, {0, 1}, {1, 1}};
    for (const auto& c : st) {
      scene.positions.push_back(glm::vec3(q.Point(c[0], c[1])));
      topo.uvs.push_back(glm::vec2(q.uv_min + glm::dvec2(c[0], c[1]) * (q.uv_max - q.uv_min)));
      topo.render_to_file_vertex.push_back(static_cast<uint32_t>(topo.render_to_file_vertex.size()));
    }
    // Counter-clockwise seen from the front (edge_s x edge_t).
    const uint32_t a = first, b = first + 1, c = first + 2, d = first + 3;
    topo.triangles.emplace_back(a, b, d);
    topo.triangles.emplace_back(a, d, c);
  }
  topo.file_triangles = topo.triangles;
  topo.num_file_vertices = static_cast<uint32_t>(scene.positions.size());
  scene.atlas.size = atlas_size;
  atlas::RasterizeTriangles(&scene.atlas);
  return scene;
}

std::optional<std::pair<int, glm::dvec3>> QuadScene::TexelPoint(int x, int y) const {
  const int triangle = atlas.triangle_id.at<int32_t>(y, x);
  if (triangle < 0) return std::nullopt;
  const int q = QuadOfTriangle(triangle);
  const Quad& quad = quads[q];
  const glm::dvec2 uv((x + 0.5) / atlas.size, 1.0 - (y + 0.5) / atlas.size);
  const glm::dvec2 st = (uv - quad.uv_min) / (quad.uv_max - quad.uv_min);
  return std::make_pair(q, quad.Point(st.x, st.y));
}

scene::FramePositions Transformed(const QuadScene& scene, const glm::dmat4& world_from_rest) {
  scene::FramePositions out;
  for (const glm::vec3& p : scene.positions) out.push_back(glm::vec3(world_from_rest * glm::dvec4(p, 1.0)));
  return out;
}

scene::CameraModel LookAtCamera(const glm::dvec3& eye, const glm::dvec3& target, int width, int height, double focal) {
  const glm::dvec3 z = glm::normalize(target - eye);  // forward
  const glm::dvec3 up = std::abs(z.z) > 0.99 ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1);
  const glm::dvec3 x = glm::normalize(glm::cross(z, up));  // right
  const glm::dvec3 y = glm::cross(z, x);                   // down
  scene::CameraModel camera;
  camera.name = "test";
  camera.width = width;
  camera.height = height;
  camera.fx = camera.fy = focal;
  camera.cx = 0.5 * (width - 1);
  camera.cy = 0.5 * (height - 1);
  for (int c = 0; c < 3; ++c) {
    camera.cam_from_world_rotation[c][0] = x[c];
    camera.cam_from_world_rotation[c][1] = y[c];
    camera.cam_from_world_rotation[c][2] = z[c];
  }
  camera.cam_from_world_translation = -(camera.cam_from_world_rotation * eye);
  return camera;
}

std::optional<glm::dvec3> CrossPlaneZ(const glm::dvec3& from, const glm::dvec3& to, double height) {
  const double dz = to.z - from.z;
  if (std::abs(dz) < 1e-12) return std::nullopt;
  const double t = (height - from.z) / dz;
  if (t <= 0.0 || t >= 1.0) return std::nullopt;
  return from + t * (to - from);
}

double InsideSquare(const glm::dvec3& p, const glm::dvec2& center, double half) {
  return half - std::max(std::abs(p.x - center.x), std::abs(p.y - center.y));
}

}  // namespace mvbrdf::resample::testing
