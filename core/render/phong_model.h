// The extended Phong model exactly as shared/NOTES.md states it, on the CPU.
// This is the reference every GPU path and every fitter is checked against.
//
//   l_k = normalize(L_k - x)      (point light)   or the light's direction
//   v   = normalize(C - x)        C = camera centre; an orthographic camera's
//                                 v is its constant -z axis (scene::CameraModel)
//   g_k = max(0, l_k . n)
//   R_k = 2 (l_k . n) n - l_k
//   h_k = max(0, R_k . v)          and h_k = 0 wherever g_k = 0
//   f   = sum_k I_k V_k a_k [ kd g_k + ks h_k^ke ]     per colour channel
// with V_k the light's visibility (shadow) and a_k = 1 / |L_k - x|^2 when
// inverse-square fall-off is on, else 1.
#ifndef MVBRDF_CORE_RENDER_PHONG_MODEL_H_
#define MVBRDF_CORE_RENDER_PHONG_MODEL_H_

#include <vector>

#include <glm/glm.hpp>

#include "core/scene/light.h"

namespace mvbrdf::render {

struct PhongParams {
  glm::vec3 kd{0.0f};  // diffuse albedo, linear RGB
  glm::vec3 ks{0.0f};  // specular coefficient, linear RGB
  glm::vec3 ke{1.0f};  // mirror-lobe exponent per channel
};

// Cosines of one light at one surface point seen from one camera.
struct LightCosines {
  float g = 0.0f;  // max(0, l.n)
  float h = 0.0f;  // max(0, R(l).v), 0 where g = 0
  float attenuation = 1.0f;  // 1/d^2 with fall-off on, else 1
  // The half-vector geometry of the other models (core/brdf/geometry.h), set
  // where g > 0 when asked for (`half_vector` below; else 0): n.v, and with
  // h = normalize(l + v) max(0, n.h) and max(0, v.h) (0 when l + v = 0).
  float n_dot_v = 0.0f;
  float n_dot_h = 0.0f;
  float v_dot_h = 0.0f;
};

LightCosines ComputeLightCosines(const scene::Light& light, const glm::vec3& point, const glm::vec3& unit_normal,
                                 const glm::vec3& camera_center, bool inverse_square_falloff);
// The same from a homogeneous viewpoint (scene::CameraModel::ViewOrigin:
// w = 1 a camera centre, w = 0 the constant direction towards an orthographic
// camera).
// `half_vector`: also n.v, n.h and v.h (measured: +32 % on assembling texel
// Samples, 7 ns a term, so only where a model reads them).
LightCosines ComputeLightCosines(const scene::Light& light, const glm::vec3& point, const glm::vec3& unit_normal,
                                 const glm::vec4& view_origin, bool inverse_square_falloff, bool half_vector = false);

// `visible[k]` is light k's visibility at the point (empty: all visible).
glm::vec3 EvaluatePhong(const PhongParams& params, const glm::vec3& point, const glm::vec3& unit_normal,
                        const glm::vec3& camera_center, const std::vector<scene::Light>& lights,
                        const std::vector<bool>& visible, bool inverse_square_falloff);
glm::vec3 EvaluatePhong(const PhongParams& params, const glm::vec3& point, const glm::vec3& unit_normal,
                        const glm::vec4& view_origin, const std::vector<scene::Light>& lights,
                        const std::vector<bool>& visible, bool inverse_square_falloff);

}  // namespace mvbrdf::render

#endif  // MVBRDF_CORE_RENDER_PHONG_MODEL_H_
