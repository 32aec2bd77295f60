// The GLSL twin of core/render/normal_detail.cc (issue #18): procedural
// tangent-space normals of the truth, and reading a tangent-space normal in
// the frame of an interpolated tangent (core/scene/tangent_frames.h).

vec3 NormalDetailAt(vec4 amplitude_wavelength, vec3 d1, vec3 d2, vec3 rest_position) {
  const float kTwoPi = 6.28318530717958647692;
  float phi1 = kTwoPi * dot(rest_position, d1) / amplitude_wavelength.y;
  float phi2 = kTwoPi * dot(rest_position, d2) / amplitude_wavelength.y;
  return normalize(vec3(amplitude_wavelength.x * sin(phi1) * cos(phi2),
                        amplitude_wavelength.x * cos(phi1) * sin(phi2), 1.0));
}

// n' = m.x T + m.y B + m.z N, T the interpolated tangent made orthogonal to
// the unit normal n, B = w (n x T).
vec3 TangentToWorld(vec3 m, vec4 tangent, vec3 n) {
  vec3 t = tangent.xyz - n * dot(n, tangent.xyz);
  float length_t = length(t);
  // Degenerate: some tangent orthogonal to n, as scene::FrameAt picks it.
  if (!(length_t > 1e-12)) {
    t = normalize(cross(abs(n.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0), n));
  } else {
    t /= length_t;
  }
  vec3 b = (tangent.w < 0.0 ? -1.0 : 1.0) * cross(n, t);
  return normalize(m.x * t + m.y * b + m.z * n);
}
