// Cook-Torrance with a GGX (Trowbridge-Reitz) distribution, height-correlated
// Smith visibility and Schlick's Fresnel: the specular BRDF of glTF 2.0's
// metallic-roughness model (its Appendix B) with KHR_materials_specular's F0,
// per unit light intensity and one colour channel, in the radiance units of
// the thesis's kd:
//
//   L = g ((1 - F / F90) kd + F D V),   g = max(0, n.l), and L = 0 where n.v <= 0,
//   a = roughness^2,
//   D = a^2 / (pi ((n.h)^2 (a^2 - 1) + 1)^2),
//   V = 0.5 / (n.l sqrt((n.v)^2 (1 - a^2) + a^2) + n.v sqrt((n.l)^2 (1 - a^2) + a^2)),
//   F = F0 (1 + (phi - 1) (1 - v.h)^5) = F0 + (F90 - F0) (1 - v.h)^5,
//   F90 = phi F0,
//
// and the diffuse weight 1 - F / F90 = (1 - 1 / phi) (1 - (1 - v.h)^5).
//
// kd here is glTF's diffuse colour over pi (c_diff / pi), so that kd means
// what it means in the thesis's model (L = kd g for a matte surface). F is
// Schlick's Fresnel with its two ends free: F0, the reflectance at normal
// incidence per channel in the data's units (the lobe's scale), and the
// ratio phi = F90 / F0, which no unit changes. A dielectric of index 1.5
// (glTF's default ior) has phi = 1 / 0.04 = 25 (kDielectricRatio, the start
// of every fit and the generator's truth); a metal's curve is flat (phi near
// 1, and no diffuse: its weight 1 - 1 / phi is 0); measured materials lie
// between (docs/models.md: MERL's plastics, paints and metals through the
// pipeline). In glTF terms it is KHR_materials_specular with ior 1.5 and
// metallic 0: specularFactor = F90, specularColorFactor = F0 / (0.04 F90) =
// 25 / phi. The model is linear in F0, as Phong is in ks, and does not depend
// on the units of the lights and images (issue #15: with F90 = 1 in absolute
// units, data exposed 0.01x made every GGX fit collapse to F0 0, roughness
// 1). Parameters: f0 >= 0, the perceptual roughness in [0.02, 1] (glTF's
// roughnessFactor; better conditioned than a: the lobe's width is about
// linear in it) and phi = f90_ratio in [1, 50] (50: a dielectric of index
// 1.33). Reciprocal; with F90 <= 1 in the lights' own units it reflects at
// most what arrives.
#ifndef MVBRDF_CORE_BRDF_GGX_H_
#define MVBRDF_CORE_BRDF_GGX_H_

#include <array>

#include "core/brdf/geometry.h"
#include "core/brdf/parameter.h"

namespace mvbrdf::brdf {

struct Ggx {
  static constexpr const char* kName = "ggx";
  static constexpr int kNumParameters = 3;  // f0, roughness, f90_ratio
  // F90 / F0 of a dielectric of index 1.5 (1 / 0.04): the ratio's start.
  static constexpr double kDielectricRatio = 25.0;
  static const std::array<Parameter, kNumParameters>& Parameters();
  // g F D V and its derivatives (`jacobian` may be null).
  static double Specular(const double* parameters, const Geometry& geometry, double* jacobian);
  // The lobe as a reconstruction draws it: V's denominator
  //   s = n.l sqrt((n.v)^2 (1 - a^2) + a^2) + n.v sqrt((n.l)^2 (1 - a^2) + a^2)
  // held at or above `support` (>= 0), the most grazing s at which the
  // capture observed the lobe (core/fit/grazing_support.h), so that the
  // peak's 1 / cos^2 growth is not extrapolated past it; 0 is Specular.
  static double SpecularWithin(const double* parameters, const Geometry& geometry, double support);
  // That s at the perceptual roughness (n.l, n.v clamped to 1; > 0 where
  // both are).
  static double VisibilityDenominator(double roughness, const Geometry& geometry);
  // The weight of the diffuse term kd g: 1 - F / F90 (the ratio's only).
  static double DiffuseWeight(const double* parameters, const Geometry& geometry, double* jacobian);
};

}  // namespace mvbrdf::brdf

#endif  // MVBRDF_CORE_BRDF_GGX_H_
