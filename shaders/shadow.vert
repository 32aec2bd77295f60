// Position-only passes: the shadow maps of core/render/shadow_maps.cc (one
// cube face or one directional map per draw) and the triangle-id pass of
// core/render/phong_renderer.cc.

layout(location = 0) in vec3 a_position;  // world units

layout(location = 0) uniform mat4 u_clip_from_world;  // a light's face or orthographic view, or a camera

out vec3 v_position;

void main() {
  v_position = a_position;
  gl_Position = u_clip_from_world * vec4(a_position, 1.0);
}
