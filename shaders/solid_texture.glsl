// Solid texture for spatially varying diffuse albedo: the GLSL twin of
// core/render/solid_texture.cc. Every operation here must stay identical to
// the C++ (32-bit unsigned wrap-around arithmetic, float maths in the same
// order), so that CPU and GPU agree to float rounding.
//
//   kd(p) = clamp(base * (1 + amplitude * noise(frequency * p + offset)), 0, 1)

// Murmur3's 32-bit finaliser: full avalanche of a 32-bit word.
uint SolidTextureMix(uint h) {
  h ^= h >> 16u;
  h *= 0x85ebca6bu;
  h ^= h >> 13u;
  h *= 0xc2b2ae35u;
  h ^= h >> 16u;
  return h;
}

// Hash of an integer lattice cell; negative coordinates wrap as uint.
uint SolidTextureHash(ivec3 cell) {
  return SolidTextureMix(uint(cell.x) + SolidTextureMix(uint(cell.y) + SolidTextureMix(uint(cell.z) + 0x9e3779b9u)));
}

// Lattice value in [-1, 1]: the top 24 bits of the hash, exact in a float.
float LatticeValue(ivec3 cell) {
  return float(SolidTextureHash(cell) >> 8u) * (2.0 / 16777215.0) - 1.0;
}

// a + (b - a) * t, spelled out: GLSL's mix() may be evaluated differently.
float SolidTextureLerp(float a, float b, float t) { return a + (b - a) * t; }

// Value noise in [-1, 1], trilinear with smoothstep weights 3t^2 - 2t^3.
float ValueNoise(vec3 p) {
  vec3 floor_p = floor(p);
  ivec3 c = ivec3(floor_p);
  vec3 f = p - floor_p;
  vec3 w = f * f * (3.0 - 2.0 * f);
  float x00 = SolidTextureLerp(LatticeValue(c + ivec3(0, 0, 0)), LatticeValue(c + ivec3(1, 0, 0)), w.x);
  float x10 = SolidTextureLerp(LatticeValue(c + ivec3(0, 1, 0)), LatticeValue(c + ivec3(1, 1, 0)), w.x);
  float x01 = SolidTextureLerp(LatticeValue(c + ivec3(0, 0, 1)), LatticeValue(c + ivec3(1, 0, 1)), w.x);
  float x11 = SolidTextureLerp(LatticeValue(c + ivec3(0, 1, 1)), LatticeValue(c + ivec3(1, 1, 1)), w.x);
  float y0 = SolidTextureLerp(x00, x10, w.y);
  float y1 = SolidTextureLerp(x01, x11, w.y);
  return SolidTextureLerp(y0, y1, w.z);
}

vec3 EvaluateSolidTexture(vec3 base, float amplitude, float frequency, vec3 offset, vec3 rest_position) {
  float n = ValueNoise(frequency * rest_position + offset);
  return clamp(base * (1.0 + amplitude * n), 0.0, 1.0);
}
