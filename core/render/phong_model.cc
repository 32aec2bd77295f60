#include "core/render/phong_model.h"

#include <algorithm>
#include <cmath>

#include "core/scene/camera_model.h"

namespace mvbrdf::render {

LightCosines ComputeLightCosines(const scene::Light& light, const glm::vec3& point, const glm::vec3& unit_normal,
                                 const glm::vec3& camera_center, bool inverse_square_falloff) {
  return ComputeLightCosines(light, point, unit_normal, glm::vec4(camera_center, 1.0f), inverse_square_falloff);
}

LightCosines ComputeLightCosines(const scene::Light& light, const glm::vec3& point, const glm::vec3& unit_normal,
                                 const glm::vec4& view_origin, bool inverse_square_falloff, bool half_vector) {
  LightCosines cosines;
  glm::vec3 l;
  if (light.directional) {
    l = glm::normalize(light.direction);
  } else {
    const glm::vec3 to_light = light.position - point;
    const float distance_squared = glm::dot(to_light, to_light);
    l = to_light / std::sqrt(distance_squared);
    // Fall-off applies to point lights only: a directional light has no distance.
    if (inverse_square_falloff) cosines.attenuation = 1.0f / distance_squared;
  }
  const float l_dot_n = glm::dot(l, unit_normal);
  // `!(x > 0)` also catches NaN (a point on the light).
  if (!(l_dot_n > 0.0f)) return cosines;
  const glm::vec3 v = scene::ViewDirection(view_origin, point);
  const glm::vec3 r = 2.0f * l_dot_n * unit_normal - l;
  cosines.g = l_dot_n;
  cosines.h = std::max(0.0f, glm::dot(r, v));
  if (!half_vector) return cosines;
  cosines.n_dot_v = glm::dot(unit_normal, v);
  const glm::vec3 sum = l + v;
  const float length = glm::length(sum);
  if (length > 0.0f) {
    const glm::vec3 half = sum / length;
    cosines.n_dot_h = std::max(0.0f, glm::dot(unit_normal, half));
    cosines.v_dot_h = std::max(0.0f, glm::dot(v, half));
  }
  return cosines;
}

glm::vec3 EvaluatePhong(const PhongParams& params, const glm::vec3& point, const glm::vec3& unit_normal,
                        const glm::vec3& camera_center, const std::vector<scene::Light>& lights,
                        const std::vector<bool>& visible, bool inverse_square_falloff) {
  return EvaluatePhong(params, point, unit_normal, glm::vec4(camera_center, 1.0f), lights, visible,
                       inverse_square_falloff);
}

glm::vec3 EvaluatePhong(const PhongParams& params, const glm::vec3& point, const glm::vec3& unit_normal,
                        const glm::vec4& view_origin, const std::vector<scene::Light>& lights,
                        const std::vector<bool>& visible, bool inverse_square_falloff) {
  glm::vec3 f(0.0f);
  for (size_t k = 0; k < lights.size(); ++k) {
    if (!visible.empty() && !visible[k]) continue;
    const LightCosines c = ComputeLightCosines(lights[k], point, unit_normal, view_origin, inverse_square_falloff);
    if (!(c.g > 0.0f)) continue;  // the specular term is zero wherever the diffuse term is
    // std::pow: 0^0 = 1 and 0^ke = 0 for ke > 0; shaders/phong_model.glsl matches.
    const glm::vec3 lobe(std::pow(c.h, params.ke.x), std::pow(c.h, params.ke.y), std::pow(c.h, params.ke.z));
    f += lights[k].intensity * c.attenuation * (params.kd * c.g + params.ks * lobe);
  }
  return f;
}

}  // namespace mvbrdf::render
