#include "core/brdf/ggx_equivalent.h"

#include <algorithm>
#include <cmath>

#include "core/brdf/blinn_phong.h"
#include "core/brdf/geometry.h"
#include "core/brdf/ggx.h"
#include "core/brdf/phong.h"

namespace mvbrdf::brdf {

double GgxRoughnessOfHalfVectorExponent(double ke_half) {
  const auto& bounds = Ggx::Parameters()[1];
  if (!(ke_half > -2.0)) return bounds.upper;
  return std::clamp(std::pow(2.0 / (ke_half + 2.0), 0.25), bounds.lower, bounds.upper);
}

ParameterVector GgxEquivalent(Model model, const ParameterVector& p) {
  if (model == Model::kGgx) return p;
  const double roughness = GgxRoughnessOfHalfVectorExponent(model == Model::kPhong ? 4.0 * p[1] : p[1]);
  const glm::dvec3 n(0.0, 0.0, 1.0);
  const Geometry head_on = GeometryOf(n, n, n);
  const double peak = model == Model::kPhong ? Phong::Specular(p.data(), head_on, nullptr)
                                             : BlinnPhong::Specular(p.data(), head_on, nullptr);
  const double unit[3] = {1.0, roughness, Ggx::kDielectricRatio};
  const double ggx_peak = Ggx::Specular(unit, head_on, nullptr);
  return {ggx_peak > 0.0 ? std::max(0.0, peak / ggx_peak) : 0.0, roughness, Ggx::kDielectricRatio};
}

ParameterVector PhongEquivalent(Model model, const ParameterVector& p) {
  if (model == Model::kPhong) return p;
  const glm::dvec3 n(0.0, 0.0, 1.0);
  const Geometry head_on = GeometryOf(n, n, n);
  double ke_half = p[1];
  double peak = 0.0;
  if (model == Model::kGgx) {
    const double a = p[1] * p[1];
    ke_half = 2.0 / std::max(a * a, 1e-300) - 2.0;
    peak = Ggx::Specular(p.data(), head_on, nullptr);
  } else {
    peak = BlinnPhong::Specular(p.data(), head_on, nullptr);
  }
  const auto& bounds = Phong::Parameters()[1];
  return {std::max(0.0, peak), std::clamp(ke_half / 4.0, bounds.lower, bounds.upper), 0.0};
}

}  // namespace mvbrdf::brdf
