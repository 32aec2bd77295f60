// A solid texture for spatially varying diffuse albedo, evaluated in rest-pose
// world coordinates, bit-for-bit the same function as shaders/solid_texture.glsl
// (up to float rounding):
//
//   kd(p) = clamp(base * (1 + amplitude * noise(frequency * p + offset)), 0, 1)
//
// noise: value noise in [-1, 1] on the integer lattice, trilinear with
// smoothstep weights (3t^2 - 2t^3), lattice values from a 32-bit integer hash
// of the cell (see solid_texture.cc; the GLSL copy must match).
#ifndef MVBRDF_CORE_RENDER_SOLID_TEXTURE_H_
#define MVBRDF_CORE_RENDER_SOLID_TEXTURE_H_

#include <cstdint>

#include <glm/glm.hpp>

namespace mvbrdf::render {

struct SolidTextureParams {
  glm::vec3 base{0.5f};     // linear RGB
  float amplitude = 0.0f;   // relative variation
  float frequency = 1.0f;   // cycles per world unit
  glm::vec3 offset{0.0f};
};

// Lattice value in [-1, 1] of integer cell (x, y, z).
float LatticeValue(int32_t x, int32_t y, int32_t z);
// Value noise in [-1, 1].
float ValueNoise(const glm::vec3& p);
glm::vec3 EvaluateSolidTexture(const SolidTextureParams& params, const glm::vec3& rest_position);

}  // namespace mvbrdf::render

#endif  // MVBRDF_CORE_RENDER_SOLID_TEXTURE_H_
