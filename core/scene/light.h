// A light as the renderer and the model evaluate it (shared/NOTES.md).
#ifndef MVBRDF_CORE_SCENE_LIGHT_H_
#define MVBRDF_CORE_SCENE_LIGHT_H_

#include <string>

#include <glm/glm.hpp>

namespace mvbrdf::scene {

// Candidate lights per scene (scene.lights; validated). Real light stages
// have 150-350; 1024 leaves room, keeps a light index in 16 bits and a
// shadow atlas at 64 channels of 16 bits (core/samples/assemble.h).
inline constexpr int kMaxLights = 1024;

// A light direction whose length is off 1 by at most this is renormalised
// (with a note in `validate`'s summary): published data is rounded to a few
// digits; farther off is refused as a mistake.
inline constexpr double kDirectionRenormaliseTolerance = 1e-3;

struct Light {
  std::string name;
  bool directional = false;
  // Point light: position in world units. Directional light: unit direction
  // from the surface towards the light.
  glm::vec3 position{0.0f};
  glm::vec3 direction{0.0f, 1.0f, 0.0f};
  glm::vec3 intensity{1.0f};  // linear RGB
};

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_LIGHT_H_
