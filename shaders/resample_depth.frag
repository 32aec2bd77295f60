// Camera depth map: inverse eye depth 1 / z (z camera-space, world units) of
// the nearest surface; the hardware depth buffer only selects the nearest.
// 1 / z is affine in image coordinates over a plane, so bilinear lookups
// between pixel centres are exact on every triangle's interior.

in float v_depth;

layout(location = 0) out float out_inverse_depth;  // 1 / world units; 0 (the clear value): no surface

void main() { out_inverse_depth = 1.0 / v_depth; }
