// The extended Phong model of core/render/phong_model.h (shared/NOTES.md), the
// GLSL twin of core/render/phong_model.cc. World units and frame throughout.
//
//   g = max(0, l.n),  R = 2 (l.n) n - l,  h = max(0, R.v), h = 0 where g = 0
//   term = a [ kd g + ks h^ke ]      (the caller multiplies by I and V)

// `l` and `v` unit vectors from the surface towards the light and the camera,
// `n` the unit normal; returns vec2(g, h).
vec2 PhongCosines(vec3 l, vec3 n, vec3 v) {
  float l_dot_n = dot(l, n);
  if (!(l_dot_n > 0.0)) return vec2(0.0);
  vec3 r = 2.0 * l_dot_n * n - l;
  return vec2(l_dot_n, max(0.0, dot(r, v)));
}

// h^ke per channel with C's pow() conventions at h = 0 (0^0 = 1, 0^ke = 0).
vec3 PhongLobe(float h, vec3 ke) {
  if (h > 0.0) return pow(vec3(h), ke);
  return vec3(equal(ke, vec3(0.0)));
}

// kd g + ks h^ke, zero where g = 0.
vec3 PhongTerm(vec3 kd, vec3 ks, vec3 ke, vec2 cosines) {
  if (!(cosines.x > 0.0)) return vec3(0.0);
  return kd * cosines.x + ks * PhongLobe(cosines.y, ke);
}
