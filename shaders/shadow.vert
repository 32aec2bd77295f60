// Shadow-map passes of core/render/phong_renderer.cc (one cube face or one
// directional map per draw).

layout(location = 0) in vec3 a_position;  // world units

layout(location = 0) uniform mat4 u_clip_from_world;  // the light's face or orthographic view

out vec3 v_position;

void main() {
  v_position = a_position;
  gl_Position = u_clip_from_world * vec4(a_position, 1.0);
}
