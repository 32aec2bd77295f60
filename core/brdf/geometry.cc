#include "core/brdf/geometry.h"

namespace mvbrdf::brdf {

Geometry GeometryOf(const glm::dvec3& n, const glm::dvec3& l, const glm::dvec3& v) {
  Geometry g;
  g.n_dot_l = glm::dot(n, l);
  g.n_dot_v = glm::dot(n, v);
  g.r_dot_v = 2.0 * g.n_dot_l * g.n_dot_v - glm::dot(l, v);
  const glm::dvec3 sum = l + v;
  const double length = glm::length(sum);
  if (length > 1e-12) {
    const glm::dvec3 h = sum / length;
    g.n_dot_h = glm::dot(n, h);
    g.v_dot_h = glm::dot(v, h);
  }
  return g;
}

}  // namespace mvbrdf::brdf
