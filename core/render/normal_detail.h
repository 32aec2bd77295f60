// Procedural surface detail below a mesh's resolution (issue #18): what
// `mvbrdf synth --normal-detail` renders and records as the truth, the same
// function as shaders/normal_detail.glsl (up to float rounding).
//
// A tangent-space normal (scene/tangent_frames.h) as a function of the rest
// position p (world units):
//   phi1 = 2 pi (p . d1) / wavelength,  phi2 = 2 pi (p . d2) / wavelength
//   m(p) = normalize(amplitude sin(phi1) cos(phi2), amplitude cos(phi1) sin(phi2), 1)
// so the surface tilts by up to atan(amplitude) per axis, in bumps of about
// `wavelength` across, attached to the surface (rest position, tangent frames
// carried by the deformation).
#ifndef MVBRDF_CORE_RENDER_NORMAL_DETAIL_H_
#define MVBRDF_CORE_RENDER_NORMAL_DETAIL_H_

#include <glm/glm.hpp>

namespace mvbrdf::render {

struct NormalDetail {
  float amplitude = 0.0f;   // peak slope per tangent axis; 0: no detail
  float wavelength = 1.0f;  // world units
  glm::vec3 d1 = glm::normalize(glm::vec3(1.0f, 0.37f, 0.61f));
  glm::vec3 d2 = glm::normalize(glm::vec3(-0.43f, 1.0f, 0.29f));
};

// m(p) above: a unit vector with z > 0.
glm::vec3 NormalDetailAt(const NormalDetail& detail, const glm::vec3& rest_position);

}  // namespace mvbrdf::render

#endif  // MVBRDF_CORE_RENDER_NORMAL_DETAIL_H_
