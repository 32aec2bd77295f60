// Test scenes for core/resample: meshes of flat quads with UVs (an atlas built
// by atlas::RasterizeTriangles, not BuildAtlas), look-at cameras, and the
// analytic surface point of any atlas texel.
#ifndef MVBRDF_CORE_RESAMPLE_RESAMPLE_TEST_UTIL_H_
#define MVBRDF_CORE_RESAMPLE_RESAMPLE_TEST_UTIL_H_

#include <glm/glm.hpp>
#include <optional>
#include <vector>

#include "core/atlas/atlas.h"
#include "core/scene/camera_model.h"
#include "core/scene/mesh.h"

namespace mvbrdf::resample::testing {

// A parallelogram p(s, t) = origin + s * edge_s + t * edge_t, s, t in [0, 1],
// front side along edge_s x edge_t, mapped affinely to the UV rectangle
// uv_min..uv_max (s -> u, t -> v).
struct Quad {
  glm::dvec3 origin{0.0};
  glm::dvec3 edge_s{1.0, 0.0, 0.0};
  glm::dvec3 edge_t{0.0, 1.0, 0.0};
  glm::dvec2 uv_min{0.0};
  glm::dvec2 uv_max{1.0};

  glm::dvec3 Point(double s, double t) const { return origin + s * edge_s + t * edge_t; }
  glm::dvec3 Normal() const { return glm::normalize(glm::cross(edge_s, edge_t)); }
};

// The quads as one mesh (two triangles each, 4 file = render vertices each)
// and its atlas of `size` texels.
struct QuadScene {
  std::vector<Quad> quads;
  atlas::Atlas atlas;
  scene::FramePositions positions;  // per file vertex, the quads' rest pose

  // Quad index of a triangle.
  static int QuadOfTriangle(int triangle) { return triangle / 2; }
  // The quad and the analytic surface point at the centre of texel (x, y)
  // (atlas image convention), or nullopt where no triangle owns the texel.
  std::optional<std::pair<int, glm::dvec3>> TexelPoint(int x, int y) const;
};

QuadScene MakeQuadScene(const std::vector<Quad>& quads, int atlas_size);

// Positions of `scene` after `world_from_rest` (applied to every file vertex).
scene::FramePositions Transformed(const QuadScene& scene, const glm::dmat4& world_from_rest);

// Camera at `eye` looking at `target`, with world +z as "up" when possible;
// fx = fy = focal, principal point at the image centre.
scene::CameraModel LookAtCamera(const glm::dvec3& eye, const glm::dvec3& target, int width, int height, double focal);

// Where the segment from `from` to `to` crosses the plane z = height, or
// nullopt when it does not.
std::optional<glm::dvec3> CrossPlaneZ(const glm::dvec3& from, const glm::dvec3& to, double height);

// Signed distance of (x, y) from the border of the axis-aligned square
// |x - cx|, |y - cy| <= half: positive inside.
double InsideSquare(const glm::dvec3& p, const glm::dvec2& center, double half);

}  // namespace mvbrdf::resample::testing

#endif  // MVBRDF_CORE_RESAMPLE_RESAMPLE_TEST_UTIL_H_
