// Camera depth map of core/resample/resampler.cc: the posed mesh seen by an
// undistorted pinhole with the camera's focal lengths (and a principal point
// shifted to cover the undistorted image), storing inverse eye depth, and the
// surface under every pixel centre (position, atlas texel, normal).

layout(location = 0) in vec3 a_position;  // world units
layout(location = 1) in vec3 a_normal;    // world frame, unit (zero where undefined)
layout(location = 2) in vec2 a_uv;        // atlas coordinates in [0, 1]^2, v up

layout(location = 0) uniform mat4 u_clip_from_world;  // pinhole projection (image row r on window row r)
layout(location = 1) uniform mat4 u_cam_from_world;   // OpenCV camera frame, z forward

out float v_depth;  // camera-space z, world units
out vec3 v_position;
out vec3 v_normal;
out vec2 v_uv;

void main() {
  v_depth = (u_cam_from_world * vec4(a_position, 1.0)).z;
  v_position = a_position;
  v_normal = a_normal;
  v_uv = a_uv;
  gl_Position = u_clip_from_world * vec4(a_position, 1.0);
}
