// A capture studio like the thesis's (§3.2, §6.1): cameras on a ring looking
// at the subject, nine point lights on the ceiling named by the compass
// (C, N, E, W, S, NE, NW, SE, SW) and the thesis's eight candidate
// configurations (Table 6.1).
//
// World frame: y up; north is -z, east is +x.
#ifndef MVBRDF_CORE_SYNTH_STUDIO_H_
#define MVBRDF_CORE_SYNTH_STUDIO_H_

#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "core/render/solid_texture.h"
#include "core/scene/camera_model.h"
#include "core/scene/light.h"

namespace mvbrdf::synth {

struct StudioOptions {
  int num_cameras = 8;
  int width = 320;
  int height = 240;
  // Vertical field of view of every camera, degrees.
  double vertical_fov_deg = 40.0;
  // Radial distortion k1 of every camera (0 = pinhole); pinhole cameras only.
  double distortion_k1 = 0.0;
  // kOrthographic: the same ring of viewpoints and image sizes with
  // orthographic cameras whose pixel size is the pinhole's at the subject's
  // centre (distance / fy), so the subject fills the image alike.
  scene::Projection projection = scene::Projection::kPinhole;
  // Light intensity (linear RGB, equal channels) of every ceiling light.
  float light_intensity = 0.6f;
};

// The subject's extent in the rest pose; the studio is laid out around it.
struct SubjectBounds {
  glm::vec3 min{0.0f};
  glm::vec3 max{0.0f};
};

struct Studio {
  std::vector<scene::CameraModel> cameras;
  std::vector<scene::Light> lights;  // C, N, E, W, S, NE, NW, SE, SW
  struct Configuration {
    std::string name;
    std::vector<std::string> lights;
  };
  std::vector<Configuration> configurations;  // the thesis's eight
};

Studio MakeStudio(const StudioOptions& options, const SubjectBounds& subject);

// `n` directional lights spread evenly over the upper hemisphere (world
// y > 0; a Fibonacci spiral of equal-area bands), named "D000", "D001", ...
// (at least three digits), each of `intensity`.
std::vector<scene::Light> MakeDomeLights(int n, float intensity);

// Name of configuration "NE,NW,SE,SW"-style from its light names.
std::string ConfigurationName(const std::vector<std::string>& lights);

// Extended Phong parameters of a material, plus its name and seed colour.
struct StudioMaterial {
  std::string name;
  glm::ivec3 seed_srgb8;  // the thesis's clustering seed (shared/NOTES.md)
  render::SolidTextureParams kd;
  glm::vec3 ks;
  glm::vec3 ke;
  // Index of refraction of the dielectric, for the models with a Fresnel
  // term (synth --brdf ggx: F0 = ((ior - 1) / (ior + 1))^2).
  float ior = 1.5f;
};

// cloth, skin, hair: kd from the thesis's seed colours (linearised), with
// spatial variation, and specular lobes from broad (cloth) to tight (hair).
std::vector<StudioMaterial> StudioMaterials();

}  // namespace mvbrdf::synth

#endif  // MVBRDF_CORE_SYNTH_STUDIO_H_
