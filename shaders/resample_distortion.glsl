// OpenCV lens distortion, the GLSL twin of scene::CameraModel::Distort
// (core/scene/camera_model.cc): normalised undistorted (x/z, y/z) ->
// normalised distorted coordinates.
//
//   r2 = x^2 + y^2
//   radial = (1 + k1 r2 + k2 r2^2 + k3 r2^3) / (1 + k4 r2 + k5 r2^2 + k6 r2^3)
//   x' = x radial + 2 p1 x y + p2 (r2 + 2 x^2)
//   y' = y radial + p1 (r2 + 2 y^2) + 2 p2 x y

// k_a = (k1, k2, p1, p2), k_b = (k3, k4, k5, k6): OpenCV's coefficient order.
vec2 DistortNormalized(vec2 u, vec4 k_a, vec4 k_b) {
  float x = u.x, y = u.y;
  float r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
  float radial = (1.0 + k_a.x * r2 + k_a.y * r4 + k_b.x * r6) / (1.0 + k_b.y * r2 + k_b.z * r4 + k_b.w * r6);
  return vec2(x * radial + 2.0 * k_a.z * x * y + k_a.w * (r2 + 2.0 * x * x),
              y * radial + k_a.z * (r2 + 2.0 * y * y) + 2.0 * k_a.w * x * y);
}
