// The true materials of `mvbrdf synth --brdf MODEL` (issue #15): each preset
// material is defined by the thesis's Phong parameters (studio.h), and
// rendered with another model by a fixed conversion to that model's two
// parameters, which the truth records (ground_truth.proto Material):
//
//   phong:        ks, ke as defined.
//   blinn-phong:  ks as defined (energy-normalised: <= 1 conserves energy),
//                 ke_half = 4 ke (a half-vector lobe as wide as the mirror
//                 lobe of exponent ke; shared/NOTES.md).
//   ggx:          F0 = ((ior - 1) / (ior + 1))^2 per the material's index of
//                 refraction (all three presets' materials are dielectrics;
//                 ggx.h's Fresnel curve is an index-1.5 dielectric's scaled
//                 by F0, so F90 = F0 / 0.04: 0.7 for skin, 1.18 for hair),
//                 roughness = (2 / (ke_half + 2))^(1/4), the GGX width whose
//                 alpha^2 = 2 / (ke_half + 2) matches that Blinn-Phong lobe
//                 (Walter et al. 2007's correspondence).
#ifndef MVBRDF_CORE_SYNTH_MODEL_MATERIALS_H_
#define MVBRDF_CORE_SYNTH_MODEL_MATERIALS_H_

#include <utility>

#include <glm/glm.hpp>

#include "core/brdf/model.h"
#include "core/synth/studio.h"

namespace mvbrdf::synth {

// The model's two parameters per channel (brdf::ParameterNames' order).
std::pair<glm::vec3, glm::vec3> ModelParametersOf(brdf::Model model, const StudioMaterial& material);

}  // namespace mvbrdf::synth

#endif  // MVBRDF_CORE_SYNTH_MODEL_MATERIALS_H_
