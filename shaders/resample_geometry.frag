// Geometry atlas pass: position and unit normal per texel; w = 1 marks the
// texel as covered (the targets are cleared to 0); and the drawn triangle
// (gl_PrimitiveID: one draw of every drawn triangle; cleared to -1).

in vec3 v_position;
in vec3 v_normal;

layout(location = 0) out vec4 out_position;  // world units
layout(location = 1) out vec4 out_normal;    // world frame, unit (0 where undefined)
layout(location = 2) out int out_triangle;   // index of the drawn triangle

void main() {
  float len = length(v_normal);
  out_position = vec4(v_position, 1.0);
  out_normal = vec4(len > 0.0 ? v_normal / len : vec3(0.0), 1.0);
  out_triangle = gl_PrimitiveID;
}
