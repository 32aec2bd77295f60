#include "core/brdf/phong.h"

#include <cmath>

namespace mvbrdf::brdf {

const std::array<Parameter, Phong::kNumParameters>& Phong::Parameters() {
  // The fitter's bounds (core/fit/phong_fit.h: PhongFitOptions).
  static const std::array<Parameter, kNumParameters> parameters = {{{"ks", 0.0, 1e6}, {"ke", 0.1, 1e4}}};
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
