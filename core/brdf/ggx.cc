#include "core/brdf/ggx.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mvbrdf::brdf {
namespace {

constexpr double kPi = 3.14159265358979323846;

// (1 - v.h)^5, v.h clamped to [0, 1].
double SchlickWeight(const Geometry& geometry) {
  const double m = 1.0 - std::clamp(geometry.v_dot_h, 0.0, 1.0);
  const double m2 = m * m;
  return m2 * m2 * m;
}

// F / F0 at Schlick weight w and ratio phi = F90 / F0: 1 + (phi - 1) w.
double FresnelShape(double w, double phi) { return 1.0 + (phi - 1.0) * w; }

}  // namespace

const std::array<Parameter, Ggx::kNumParameters>& Ggx::Parameters() {
  static const std::array<Parameter, kNumParameters> parameters = {
      {{"f0", 0.0, std::numeric_limits<double>::infinity()}, {"roughness", 0.02, 1.0}, {"f90_ratio", 1.0, 50.0}}};
  return parameters;
}

double Ggx::Specular(const double* p, const Geometry& geometry, double* jacobian) {
  if (jacobian != nullptr) jacobian[0] = jacobian[1] = jacobian[2] = 0.0;
  const double nl = geometry.n_dot_l, nv = geometry.n_dot_v;
  if (!(nl > 0.0) || !(nv > 0.0)) return 0.0;
  const double nl1 = std::min(nl, 1.0), nv1 = std::min(nv, 1.0);
  const double c = std::clamp(geometry.n_dot_h, 0.0, 1.0);
  const double f0 = p[0], roughness = p[1], phi = p[2];
  const double a = roughness * roughness, a2 = a * a;
  // D and dD/da.
  const double q = c * c * (a2 - 1.0) + 1.0;
  const double d = a2 / (kPi * q * q);
  const double dd_da = 2.0 * a * (q - 2.0 * a2 * c * c) / (kPi * q * q * q);
  // V and dV/da.
  const double root_v = std::sqrt(nv1 * nv1 * (1.0 - a2) + a2), root_l = std::sqrt(nl1 * nl1 * (1.0 - a2) + a2);
  const double s = nl1 * root_v + nv1 * root_l;
  const double v = 0.5 / s;
  const double ds_da = nl1 * a * (1.0 - nv1 * nv1) / root_v + nv1 * a * (1.0 - nl1 * nl1) / root_l;
  const double dv_da = -0.5 * ds_da / (s * s);
  // F = F0 (1 + (phi - 1) w).
  const double w = SchlickWeight(geometry);
  const double dfdf0 = FresnelShape(w, phi);
  const double f = f0 * dfdf0;
  if (jacobian != nullptr) {
    jacobian[0] = nl * dfdf0 * d * v;
    jacobian[1] = nl * f * (dd_da * v + d * dv_da) * 2.0 * roughness;
    jacobian[2] = nl * f0 * w * d * v;
  }
  return nl * f * d * v;
}

double Ggx::VisibilityDenominator(double roughness, const Geometry& geometry) {
  const double nl = std::min(geometry.n_dot_l, 1.0), nv = std::min(geometry.n_dot_v, 1.0);
  const double a = roughness * roughness, a2 = a * a;
  return nl * std::sqrt(nv * nv * (1.0 - a2) + a2) + nv * std::sqrt(nl * nl * (1.0 - a2) + a2);
}

double Ggx::SpecularWithin(const double* p, const Geometry& geometry, double support) {
  const double specular = Specular(p, geometry, nullptr);
  if (!(specular > 0.0)) return specular;
  // V = 0.5 / s becomes 0.5 / max(s, support).
  const double s = VisibilityDenominator(p[1], geometry);
  return s >= support ? specular : specular * (s / support);
}

double Ggx::DiffuseWeight(const double* p, const Geometry& geometry, double* jacobian) {
  // 1 - F / F90 = (1 - 1 / phi) (1 - w): what the surface does not reflect
  // specularly, a fraction (independent of the data's units, so of F0).
  const double phi = p[2], m = 1.0 - SchlickWeight(geometry);
  if (jacobian != nullptr) {
    jacobian[0] = jacobian[1] = 0.0;
    jacobian[2] = m / (phi * phi);
  }
  return (1.0 - 1.0 / phi) * m;
}

}  // namespace mvbrdf::brdf
