// Cook-Torrance with a GGX (Trowbridge-Reitz) distribution, height-correlated
// Smith visibility and Schlick's Fresnel: the specular BRDF of glTF 2.0's
// metallic-roughness model (its Appendix B) with KHR_materials_specular's F0,
// per unit light intensity and one colour channel, in the radiance units of
// the thesis's kd:
//
//   L = g ((1 - F) kd + F D V),   g = max(0, n.l), and L = 0 where n.v <= 0,
//   a = roughness^2,
//   D = a^2 / (pi ((n.h)^2 (a^2 - 1) + 1)^2),
//   V = 0.5 / (n.l sqrt((n.v)^2 (1 - a^2) + a^2) + n.v sqrt((n.l)^2 (1 - a^2) + a^2)),
//   F = F0 + (1 - F0) (1 - v.h)^5.
//
// kd here is glTF's diffuse colour over pi (c_diff / pi), so that kd means
// what it means in the thesis's model (L = kd g for a matte surface); F0 is
// the reflectance at normal incidence per channel (for a dielectric glTF's
// 0.04 x specularColorFactor x specularFactor, for a metal its baseColor).
// Parameters: f0 in [0, 1] and the perceptual roughness in [0.02, 1] (glTF's
// roughnessFactor; better conditioned than a: the lobe's width is about
// linear in it). Reciprocal; with F0 <= 1 it reflects at most what arrives.
// F0 is a reflectance: it has a meaning only where kd and the images are in
// the lights' own units; data in other units need a scale beside it (a fit's
// concern, issue #15 item 3), since results must not depend on units.
#ifndef MVBRDF_CORE_BRDF_GGX_H_
#define MVBRDF_CORE_BRDF_GGX_H_

#include <array>

#include "core/brdf/geometry.h"
#include "core/brdf/parameter.h"

namespace mvbrdf::brdf {

struct Ggx {
  static constexpr const char* kName = "ggx";
  static constexpr int kNumParameters = 2;  // f0, roughness
  static const std::array<Parameter, kNumParameters>& Parameters();
  // g F D V and its derivatives (`jacobian` may be null).
  static double Specular(const double* parameters, const Geometry& geometry, double* jacobian);
  // The weight of the diffuse term kd g: 1 - F, and its derivatives.
  static double DiffuseWeight(const double* parameters, const Geometry& geometry, double* jacobian);
};

}  // namespace mvbrdf::brdf

#endif  // MVBRDF_CORE_BRDF_GGX_H_
