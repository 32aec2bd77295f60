// Point-light cube shadow map: stores the distance to the light, divided by
// the light's shadow range so that it fits the [0, 1] depth buffer.

in vec3 v_position;

layout(location = 1) uniform vec3 u_light_position;  // world units
layout(location = 2) uniform float u_inverse_range;  // 1 / world length of depth 1

void main() { gl_FragDepth = distance(v_position, u_light_position) * u_inverse_range; }
