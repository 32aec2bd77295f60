#include "core/render/solid_texture.h"

#include <cmath>

namespace mvbrdf::render {
namespace {

// Murmur3's 32-bit finaliser. uint32_t arithmetic wraps exactly like GLSL's
// uint; shaders/solid_texture.glsl has the same function (SolidTextureMix).
uint32_t Mix(uint32_t h) {
  h ^= h >> 16;
  h *= 0x85ebca6bu;
  h ^= h >> 13;
  h *= 0xc2b2ae35u;
  h ^= h >> 16;
  return h;
}

uint32_t Hash(int32_t x, int32_t y, int32_t z) {
  // int32 -> uint32 keeps the bit pattern (modular), as GLSL's uint(int).
  return Mix(static_cast<uint32_t>(x) + Mix(static_cast<uint32_t>(y) + Mix(static_cast<uint32_t>(z) + 0x9e3779b9u)));
}

float Lerp(float a, float b, float t) { return a + (b - a) * t; }

}  // namespace

float LatticeValue(int32_t x, int32_t y, int32_t z) {
  // Top 24 bits: exactly representable as float, so both sides agree bit for bit.
  return static_cast<float>(Hash(x, y, z) >> 8) * (2.0f / 16777215.0f) - 1.0f;
}

float ValueNoise(const glm::vec3& p) {
  const glm::vec3 floor_p = glm::floor(p);
  const int32_t x = static_cast<int32_t>(floor_p.x);
  const int32_t y = static_cast<int32_t>(floor_p.y);
  const int32_t z = static_cast<int32_t>(floor_p.z);
  const glm::vec3 f = p - floor_p;
  const glm::vec3 w = f * f * (3.0f - 2.0f * f);
  const float x00 = Lerp(LatticeValue(x, y, z), LatticeValue(x + 1, y, z), w.x);
  const float x10 = Lerp(LatticeValue(x, y + 1, z), LatticeValue(x + 1, y + 1, z), w.x);
  const float x01 = Lerp(LatticeValue(x, y, z + 1), LatticeValue(x + 1, y, z + 1), w.x);
  const float x11 = Lerp(LatticeValue(x, y + 1, z + 1), LatticeValue(x + 1, y + 1, z + 1), w.x);
  return Lerp(Lerp(x00, x10, w.y), Lerp(x01, x11, w.y), w.z);
}

glm::vec3 EvaluateSolidTexture(const SolidTextureParams& params, const glm::vec3& rest_position) {
  const float n = ValueNoise(params.frequency * rest_position + params.offset);
  return glm::clamp(params.base * (1.0f + params.amplitude * n), 0.0f, 1.0f);
}

}  // namespace mvbrdf::render
