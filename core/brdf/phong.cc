#include "core/brdf/phong.h"

#include <cmath>
#include <limits>

namespace mvbrdf::brdf {

const std::array<Parameter, Phong::kNumParameters>& Phong::Parameters() {
  // ks has no upper bound of its own: it is in the data's intensity units
  // (a fit bounds it relative to them, as core/fit/phong_fit.h's ks_max);
  // ke as the fitter's ke_min, ke_max.
  static const std::array<Parameter, kNumParameters> parameters = {
      {{"ks", 0.0, std::numeric_limits<double>::infinity()}, {"ke", 1.0, 1e4}}};
  return parameters;
}

double Phong::Specular(const double* p, const Geometry& geometry, double* jacobian) {
  if (jacobian != nullptr) jacobian[0] = jacobian[1] = 0.0;
  const double g = geometry.n_dot_l, h = std::min(geometry.r_dot_v, 1.0);
  if (!(g > 0.0) || !(h > 0.0)) return 0.0;
  const double power = h >= 1.0 ? 1.0 : std::exp(p[1] * std::log(h));
  if (jacobian != nullptr) {
    jacobian[0] = power;
    jacobian[1] = h >= 1.0 ? 0.0 : p[0] * power * std::log(h);
  }
  return p[0] * power;
}

double Phong::DiffuseWeight(const double*, const Geometry&, double* jacobian) {
  if (jacobian != nullptr) jacobian[0] = jacobian[1] = 0.0;
  return 1.0;
}

}  // namespace mvbrdf::brdf
