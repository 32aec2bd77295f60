#include "core/synth/model_materials.h"

#include <cmath>

#include "core/brdf/ggx_equivalent.h"

namespace mvbrdf::synth {

std::pair<glm::vec3, glm::vec3> ModelParametersOf(brdf::Model model, const StudioMaterial& material) {
  switch (model) {
    case brdf::Model::kPhong:
      return {material.ks, material.ke};
    case brdf::Model::kBlinnPhong:
      return {material.ks, 4.0f * material.ke};
    case brdf::Model::kGgx: {
      const float r = (material.ior - 1.0f) / (material.ior + 1.0f);
      glm::vec3 roughness;
      for (int c = 0; c < 3; ++c) {
        roughness[c] = static_cast<float>(brdf::GgxRoughnessOfHalfVectorExponent(4.0 * material.ke[c]));
      }
      return {glm::vec3(r * r), roughness};
    }
  }
  return {material.ks, material.ke};
}

}  // namespace mvbrdf::synth
