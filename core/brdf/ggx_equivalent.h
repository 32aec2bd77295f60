// Any model's lobe as the GGX lobe of ggx.h that resembles it most simply
// (issue #16: the glTF export speaks GGX only), per colour channel:
//
//   roughness: the lobe's width. Blinn-Phong's exponent ke maps to GGX's
//     alpha^2 = 2 / (ke + 2) (Walter et al. 2007), roughness = alpha^(1/2);
//     the thesis's mirror lobe of exponent ke is about as wide as a half-vector
//     lobe of exponent 4 ke (shared/NOTES.md). Clamped to GGX's bounds.
//   F0: the peak, matched head on (light and view along the normal, h = n),
//     F0 = S_model(p; head on) / S_ggx(F0 = 1, roughness; head on).
//
// GGX itself maps to itself (its head-on peak is F0's whatever its ratio). `synth --brdf ggx` converts its Phong presets by
// the same width rule (core/synth/model_materials.h). PhongEquivalent is the
// way back to the thesis's mirror lobe (the OBJ + MTL export), by the same
// rules: GgxEquivalent(kPhong, PhongEquivalent(m, p)) = GgxEquivalent(m, p)
// within the bounds.
#ifndef MVBRDF_CORE_BRDF_GGX_EQUIVALENT_H_
#define MVBRDF_CORE_BRDF_GGX_EQUIVALENT_H_

#include <array>

#include "core/brdf/model.h"

namespace mvbrdf::brdf {

// GGX's roughness of a Blinn-Phong (half-vector) exponent, within GGX's bounds.
double GgxRoughnessOfHalfVectorExponent(double ke_half);

// {F0, roughness, f90_ratio} of the model's parameters (ParameterNames'
// order); the ratio of a model without one is a dielectric's (25).
ParameterVector GgxEquivalent(Model model, const ParameterVector& p);

// {ks, ke} of the thesis's Phong: ke = ke_half / 4 (ke_half = 2 / alpha^2 - 2
// for GGX), ks = the model's head-on peak; ke within Phong's bounds.
ParameterVector PhongEquivalent(Model model, const ParameterVector& p);

}  // namespace mvbrdf::brdf

#endif  // MVBRDF_CORE_BRDF_GGX_EQUIVALENT_H_
