// A light as the renderer and the model evaluate it (shared/NOTES.md).
#ifndef MVBRDF_CORE_SCENE_LIGHT_H_
#define MVBRDF_CORE_SCENE_LIGHT_H_

#include <string>

#include <glm/glm.hpp>

namespace mvbrdf::scene {

// The most candidate lights a run takes (scene.lights): validation refuses
// more, so that `validate` and `run` agree. The one place this limit lives;
// core/samples (samples::kMaxLights), the resampler's shadow atlas and the
// renderer use it.
inline constexpr int kMaxLights = 16;

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
