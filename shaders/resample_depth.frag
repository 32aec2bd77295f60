// Camera depth map: linear eye depth (camera-space z, world units) of the
// nearest surface; the hardware depth buffer only selects the nearest.

in float v_depth;

layout(location = 0) out float out_depth;

void main() { out_depth = v_depth; }
