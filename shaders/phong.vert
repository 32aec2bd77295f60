// Main pass of core/render/phong_renderer.cc: passes the world-space surface
// attributes of each render vertex to phong.frag. The same shading draws
// either a camera image (Render) or the atlas (RenderAtlas, u_uv_space != 0),
// where the triangle is placed at its UVs instead of its projection.

layout(location = 0) in vec3 a_position;       // world units, this frame's pose
layout(location = 1) in vec3 a_normal;         // world frame, unit
layout(location = 2) in vec3 a_rest_position;  // rest pose, solid-texture coordinates
layout(location = 3) in vec2 a_uv;             // texture coordinates, v = 0 at the bottom row
// Tangent (xyz) and handedness (w), core/scene/tangent_frames.h; read only
// with a normal detail or atlas.
layout(location = 4) in vec4 a_tangent;

// OpenCV pinhole camera as a GL projection (see phong_renderer.cc): image row r
// lands on window row r, so the read-back is top row first.
layout(location = 0) uniform mat4 u_clip_from_world;
// Nonzero: gl_Position = the vertex's uv mapped from [0, 1]^2 to clip
// [-1, 1]^2 with w = 1 (so attributes interpolate affinely in UV space) and
// u_clip_from_world is ignored. v = 0 lands on window row 0, the bottom.
layout(location = 4) uniform int u_uv_space;

out vec3 v_position;
out vec3 v_normal;
out vec3 v_rest_position;
out vec2 v_uv;
out vec4 v_tangent;

void main() {
  v_position = a_position;
  v_normal = a_normal;
  v_rest_position = a_rest_position;
  v_uv = a_uv;
  v_tangent = a_tangent;
  gl_Position = u_uv_space != 0 ? vec4(2.0 * a_uv - 1.0, 0.0, 1.0) : u_clip_from_world * vec4(a_position, 1.0);
}
