// Slope-scaled shadow-map bias, world units (the rule of shaders/phong.frag,
// kept here so that other passes can include it): a nearest shadow texel of
// world size `texel_world` covers surface depths up to about half a texel
// diagonal times tan(angle between light and normal) away from its centre.

float ShadowBias(float texel_world, vec3 l, vec3 normal) {
  float c = abs(dot(l, normal));
  float tan_theta = sqrt(max(0.0, 1.0 - c * c)) / max(c, 1e-4);
  return texel_world * (1.0 + 1.5 * min(tan_theta, 10.0));
}
