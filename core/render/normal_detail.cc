#include "core/render/normal_detail.h"

#include <cmath>

namespace mvbrdf::render {

glm::vec3 NormalDetailAt(const NormalDetail& detail, const glm::vec3& rest_position) {
  constexpr float kTwoPi = 6.28318530717958647692f;
  const float phi1 = kTwoPi * glm::dot(rest_position, detail.d1) / detail.wavelength;
  const float phi2 = kTwoPi * glm::dot(rest_position, detail.d2) / detail.wavelength;
  return glm::normalize(glm::vec3(detail.amplitude * std::sin(phi1) * std::cos(phi2),
                                  detail.amplitude * std::cos(phi1) * std::sin(phi2), 1.0f));
}

}  // namespace mvbrdf::render
