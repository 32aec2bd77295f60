// Shadow atlas pass of core/resample/resampler.cc: for every texel, bit
// shadow.w of the output is set where light k of this pass is visible from the
// texel's surface point (shadow-map test only; the cosine is left to later
// stages). One pass holds up to 16 lights, one 16-bit channel of the atlas.
// The light block mirrors GpuShadowLight in resampler.cc.

#include "resample_shadow_bias.glsl"

const int kMaxLights = 16;

struct GpuShadowLight {
  // xyz: position (point light, world units) or unit direction towards the
  // light (directional); w: 1 point, 0 directional.
  vec4 position;
  // x: layer in the shadow-map array of the light's kind; y: world length of
  // depth 1; z: texel size (point: radians at the face centre; directional: world units).
  vec4 shadow;
  mat4 shadow_from_world;  // directional: world -> (s, t, depth) in [0, 1]^3
};

layout(std140, binding = 0) uniform ShadowLightBlock {
  ivec4 u_light_count;  // x: number of lights
  GpuShadowLight u_lights[kMaxLights];
};

layout(binding = 0) uniform sampler2D u_position_map;              // RGBA32F: world xyz, w = 1 covered
layout(binding = 1) uniform sampler2D u_normal_map;                // RGBA32F: unit world normal
layout(binding = 2) uniform samplerCubeArray u_point_shadows;      // distance to the light / shadow.y
layout(binding = 3) uniform sampler2DArray u_directional_shadows;  // orthographic depth

layout(location = 0) out uint out_visible;  // bit shadow.w: that light visible

bool PointLightVisible(GpuShadowLight light, vec3 p, vec3 n) {
  vec3 to_light = light.position.xyz - p;
  float distance_to_light = length(to_light);
  vec3 l = to_light / max(distance_to_light, 1e-30);
  float stored = textureLod(u_point_shadows, vec4(-l, light.shadow.x), 0.0).r * light.shadow.y;
  float bias = ShadowBias(distance_to_light * light.shadow.z, l, n);
  return distance_to_light - bias <= stored;
}

bool DirectionalLightVisible(GpuShadowLight light, vec3 p, vec3 n) {
  vec3 s = (light.shadow_from_world * vec4(p, 1.0)).xyz;
  if (any(lessThan(s, vec3(0.0))) || any(greaterThan(s, vec3(1.0)))) return true;
  float stored = textureLod(u_directional_shadows, vec3(s.xy, light.shadow.x), 0.0).r;
  float bias = ShadowBias(light.shadow.z, light.position.xyz, n) / light.shadow.y;
  return s.z - bias <= stored;
}

void main() {
  out_visible = 0u;
  ivec2 texel = ivec2(gl_FragCoord.xy);
  vec4 position = texelFetch(u_position_map, texel, 0);
  if (position.w < 0.5) return;
  vec3 n = texelFetch(u_normal_map, texel, 0).xyz;
  uint bits = 0u;
  for (int k = 0; k < u_light_count.x; ++k) {
    GpuShadowLight light = u_lights[k];
    bool visible = light.position.w > 0.5 ? PointLightVisible(light, position.xyz, n)
                                          : DirectionalLightVisible(light, position.xyz, n);
    if (visible) bits |= 1u << uint(light.shadow.w);
  }
  out_visible = bits;
}
