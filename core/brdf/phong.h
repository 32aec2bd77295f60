// The thesis's extended Phong model (Eq. 2.9 with shared/NOTES.md's
// corrections), per unit light intensity and one colour channel:
//
//   L = kd g + ks h^ke,   g = max(0, n.l),  h = min(1, max(0, R(l).v)),
//   and h = 0 where g = 0 (the specular term of a light is zero wherever its
//   diffuse term is).
//
// A mirror lobe without a cosine: neither reciprocal nor energy-conserving
// (brdf_test.cc shows both); kept as the default for the thesis's tables.
// Parameters: ks (same units as kd), ke (the lobe's exponent).
#ifndef MVBRDF_CORE_BRDF_PHONG_H_
#define MVBRDF_CORE_BRDF_PHONG_H_

#include <array>

#include "core/brdf/geometry.h"
#include "core/brdf/parameter.h"

namespace mvbrdf::brdf {

struct Phong {
  static constexpr const char* kName = "phong";
  static constexpr int kNumParameters = 2;  // ks, ke
  static const std::array<Parameter, kNumParameters>& Parameters();
  // The specular radiance ks h^ke; `jacobian` (kNumParameters, may be null)
  // receives its derivatives with respect to the parameters.
  static double Specular(const double* parameters, const Geometry& geometry, double* jacobian);
  // The weight of the diffuse term kd g: 1.
  static double DiffuseWeight(const double* parameters, const Geometry& geometry, double* jacobian);
};

}  // namespace mvbrdf::brdf

#endif  // MVBRDF_CORE_BRDF_PHONG_H_
