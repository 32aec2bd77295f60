// Where a ray meets a triangle's plane (Moller-Trumbore, in double precision):
// origin + distance direction = p0 + b1 (p1 - p0) + b2 (p2 - p0). The caller
// decides what counts as inside (b1, b2 >= 0 and b1 + b2 <= 1, with its own
// tolerance) and in front (distance > 0).
#ifndef MVBRDF_CORE_SCENE_RAY_TRIANGLE_H_
#define MVBRDF_CORE_SCENE_RAY_TRIANGLE_H_

#include <cmath>
#include <glm/glm.hpp>
#include <optional>

namespace mvbrdf::scene {

struct RayTriangleHit {
  double distance = 0.0;  // along `direction`, in its lengths
  double b1 = 0.0, b2 = 0.0;  // barycentric weights of p1 and p2 (p0's: 1 - b1 - b2)
};

// nullopt when the ray runs parallel to the plane (|det| <= 1e-300).
inline std::optional<RayTriangleHit> IntersectRayTriangle(const glm::dvec3& origin, const glm::dvec3& direction,
                                                          const glm::dvec3& p0, const glm::dvec3& p1,
                                                          const glm::dvec3& p2) {
  const glm::dvec3 e1 = p1 - p0, e2 = p2 - p0;
  const glm::dvec3 h = glm::cross(direction, e2);
  const double det = glm::dot(e1, h);
  if (!(std::abs(det) > 1e-300)) return std::nullopt;
  const glm::dvec3 s = origin - p0;
  const glm::dvec3 q = glm::cross(s, e1);
  return RayTriangleHit{glm::dot(e2, q) / det, glm::dot(s, h) / det, glm::dot(direction, q) / det};
}

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_RAY_TRIANGLE_H_
