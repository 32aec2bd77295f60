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
//   F = F0 (1 + (1 / 0.04 - 1) (1 - v.h)^5) = F0 + (F90 - F0) (1 - v.h)^5,
//   F90 = F0 / 0.04,
//
// and the diffuse weight 1 - F / F90 = 0.96 (1 - (1 - v.h)^5).
//
// kd here is glTF's diffuse colour over pi (c_diff / pi), so that kd means
// what it means in the thesis's model (L = kd g for a matte surface). F is
// Schlick's Fresnel of a dielectric of index 1.5 (glTF's default ior: F0 /
// F90 = kF0 = 0.04) scaled by the lobe: F0 is the reflectance at normal
// incidence per channel in the data's units, and F90 = F0 / 0.04 is in glTF
// KHR_materials_specular's specularFactor (F90) and specularColorFactor (F0 /
// (0.04 F90)) with ior 1.5 and metallic 0. So the model is linear in F0, as
// Phong is in ks, and does not depend on the units of the lights and images
// (issue #15: with F90 = 1, data exposed 0.01x made every GGX fit collapse to
// F0 0, roughness 1; measured in docs/models.md). What it cannot represent is
// a metal's flat Fresnel curve (F90 = F0 of a metal in absolute units): a
// metal's grazing response comes out up to 25x too strong. Parameters: f0 >= 0
// and the perceptual roughness in [0.02, 1] (glTF's roughnessFactor; better
// conditioned than a: the lobe's width is about linear in it). Reciprocal;
// with F0 <= 0.04 in the lights' own units it reflects at most what arrives.
#ifndef MVBRDF_CORE_BRDF_GGX_H_
#define MVBRDF_CORE_BRDF_GGX_H_

#include <array>

#include "core/brdf/geometry.h"
#include "core/brdf/parameter.h"

namespace mvbrdf::brdf {

struct Ggx {
  static constexpr const char* kName = "ggx";
  static constexpr int kNumParameters = 2;  // f0, roughness
  // F0 / F90 of the Fresnel curve: a dielectric of index 1.5.
  static constexpr double kF0 = 0.04;
  static const std::array<Parameter, kNumParameters>& Parameters();
  // g F D V and its derivatives (`jacobian` may be null).
  static double Specular(const double* parameters, const Geometry& geometry, double* jacobian);
  // The weight of the diffuse term kd g: 1 - F / F90 (no parameter's).
  static double DiffuseWeight(const double* parameters, const Geometry& geometry, double* jacobian);
};

}  // namespace mvbrdf::brdf

#endif  // MVBRDF_CORE_BRDF_GGX_H_
