#include "core/brdf/blinn_phong.h"

#include <cmath>
#include <limits>

namespace mvbrdf::brdf {
namespace {

constexpr double kPi = 3.14159265358979323846;

// (ke + 2)(ke + 4) / (8 pi (2^(-ke/2) + ke)) and its derivative: the lobe
// times n.l integrates to 1 for light and camera along the normal
// (Akenine-Moller et al., Real-Time Rendering, 3rd ed., 7.6); the common
// (ke + 8) / (8 pi) overshoots it (1.039 at ke = 40, brdf_test.cc).
double Normalisation(double ke, double* derivative) {
  const double e = std::exp2(-0.5 * ke);
  const double top = (ke + 2.0) * (ke + 4.0), bottom = 8.0 * kPi * (e + ke);
  *derivative = ((2.0 * ke + 6.0) * bottom - top * 8.0 * kPi * (1.0 - 0.5 * std::log(2.0) * e)) / (bottom * bottom);
  return top / bottom;
}

}  // namespace

const std::array<Parameter, BlinnPhong::kNumParameters>& BlinnPhong::Parameters() {
  // ks in the data's intensity units, like kd (<= 1 conserves energy only
  // where those are the lights' own); ke up to 4x the mirror lobe's 1e4.
  static const std::array<Parameter, kNumParameters> parameters = {
      {{"ks", 0.0, std::numeric_limits<double>::infinity()}, {"ke", 1.0, 4e4}}};
  return parameters;
}

double BlinnPhong::Specular(const double* p, const Geometry& geometry, double* jacobian) {
  if (jacobian != nullptr) jacobian[0] = jacobian[1] = 0.0;
  const double g = geometry.n_dot_l, c = std::min(geometry.n_dot_h, 1.0);
  if (!(g > 0.0) || !(geometry.n_dot_v > 0.0) || !(c > 0.0)) return 0.0;
  const double power = c >= 1.0 ? 1.0 : std::exp(p[1] * std::log(c));
  double d_normalisation = 0;
  const double normalisation = Normalisation(p[1], &d_normalisation);
  if (jacobian != nullptr) {
    jacobian[0] = g * normalisation * power;
    jacobian[1] = g * p[0] * power * (d_normalisation + (c >= 1.0 ? 0.0 : normalisation * std::log(c)));
  }
  return g * p[0] * normalisation * power;
}

double BlinnPhong::DiffuseWeight(const double*, const Geometry&, double* jacobian) {
  if (jacobian != nullptr) jacobian[0] = jacobian[1] = 0.0;
  return 1.0;
}

}  // namespace mvbrdf::brdf
