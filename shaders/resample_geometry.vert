// Geometry atlas pass of core/resample/resampler.cc: the posed mesh drawn in
// atlas space, so that every covered texel receives the world position and
// normal of its surface point for this frame.

layout(location = 0) in vec3 a_position;  // world units, this frame's pose
layout(location = 1) in vec3 a_normal;    // world frame, unit (zero where undefined)
layout(location = 2) in vec2 a_uv;        // atlas coordinates in [0, 1]^2, v up

out vec3 v_position;
out vec3 v_normal;

void main() {
  v_position = a_position;
  v_normal = a_normal;
  // y = 1 - 2v puts v = 1 on window row 0, so that window row r is atlas image
  // row r (core/atlas/atlas.h: row 0 at the top) and every read-back and
  // texelFetch needs no flip. No culling is used; the mirrored winding is harmless.
  gl_Position = vec4(2.0 * a_uv.x - 1.0, 1.0 - 2.0 * a_uv.y, 0.0, 1.0);
}
