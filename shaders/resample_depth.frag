// Camera depth map: inverse eye depth 1 / z (z camera-space, world units) of
// the nearest surface; the hardware depth buffer only selects the nearest.
// 1 / z is affine in image coordinates over a plane, so bilinear lookups
// between pixel centres are exact on every triangle's interior.
// The other two targets hold the surface at the pixel centre: world position
// with the atlas texel it lies in (index + 1; 0 = no surface), and the unit
// interpolated normal — exact per-pixel Samples, free of the atlas's
// resampling blur (Resampler::Surface). The fourth holds the drawn triangle
// (gl_PrimitiveID, as the geometry atlas's; cleared to -1).

in float v_depth;
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;

layout(location = 8) uniform int u_atlas_size;  // texels per side

layout(location = 0) out float out_inverse_depth;  // 1 / world units; 0 (the clear value): no surface
layout(location = 1) out vec4 out_position_texel;  // xyz world units; w = texel index + 1
layout(location = 2) out vec4 out_normal;          // world frame, unit
layout(location = 3) out int out_triangle;         // index of the drawn triangle

void main() {
  out_inverse_depth = 1.0 / v_depth;
  int column = clamp(int(floor(v_uv.x * float(u_atlas_size))), 0, u_atlas_size - 1);
  int row = clamp(int(floor((1.0 - v_uv.y) * float(u_atlas_size))), 0, u_atlas_size - 1);
  out_position_texel = vec4(v_position, float(row * u_atlas_size + column + 1));
  float len = length(v_normal);
  out_normal = vec4(len > 0.0 ? v_normal / len : vec3(0.0), 1.0);
  out_triangle = gl_PrimitiveID;
}
