// Energy-normalised Blinn-Phong, per unit light intensity and one colour
// channel, in the radiance units of the thesis's kd:
//
//   L = g (kd + ks N(ke) c^ke),   g = max(0, n.l),  c = max(0, n.h),
//   N(ke) = (ke + 2)(ke + 4) / (8 pi (2^(-ke/2) + ke)),
//   and L = 0 where n.l <= 0 or n.v <= 0.
//
// Reciprocal, and with ks <= 1 it reflects at most what arrives (N makes the
// lobe integrate to 1 seen along the normal; brdf_test.cc integrates it). A half-vector
// exponent is about 4x a mirror lobe's for the same lobe (shared/NOTES.md).
// Parameters: ks (in kd's units; <= 1 conserves energy in the lights' own), ke.
#ifndef MVBRDF_CORE_BRDF_BLINN_PHONG_H_
#define MVBRDF_CORE_BRDF_BLINN_PHONG_H_

#include <array>

#include "core/brdf/geometry.h"
#include "core/brdf/parameter.h"

namespace mvbrdf::brdf {

struct BlinnPhong {
  static constexpr const char* kName = "blinn-phong";
  static constexpr int kNumParameters = 2;  // ks, ke
  static const std::array<Parameter, kNumParameters>& Parameters();
  // g ks N(ke) c^ke and its derivatives (`jacobian` may be null).
  static double Specular(const double* parameters, const Geometry& geometry, double* jacobian);
  // The weight of the diffuse term kd g: 1.
  static double DiffuseWeight(const double* parameters, const Geometry& geometry, double* jacobian);
};

}  // namespace mvbrdf::brdf

#endif  // MVBRDF_CORE_BRDF_BLINN_PHONG_H_
