// The geometry of one observation as every BRDF model of this layer reads
// it: the cosines between the unit surface normal n, the unit direction to
// the light l and the unit direction to the camera v (shared/NOTES.md), all
// in one frame, and their half vector h = normalize(l + v).
//
//   n_dot_l = n.l (the diffuse cosine g),  n_dot_v = n.v,
//   n_dot_h = n.h,  v_dot_h = v.h (= l.h),
//   r_dot_v = R(l).v with R(l) = 2 (l.n) n - l (the thesis's mirror lobe).
//
// Samples store these cosines, not the directions, so that a model needs no
// frame (issue #15 item 2).
#ifndef MVBRDF_CORE_BRDF_GEOMETRY_H_
#define MVBRDF_CORE_BRDF_GEOMETRY_H_

#include <glm/glm.hpp>

namespace mvbrdf::brdf {

struct Geometry {
  double n_dot_l = 0, n_dot_v = 0, n_dot_h = 0, v_dot_h = 0, r_dot_v = 0;
};

// From unit vectors n, l, v (not checked). A light and camera in the same
// direction give h = l = v; opposite ones (l + v = 0) give n_dot_h = v_dot_h = 0.
Geometry GeometryOf(const glm::dvec3& n, const glm::dvec3& l, const glm::dvec3& v);

}  // namespace mvbrdf::brdf

#endif  // MVBRDF_CORE_BRDF_GEOMETRY_H_
