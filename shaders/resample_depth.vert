// Camera depth map of core/resample/resampler.cc: the posed mesh seen by an
// undistorted pinhole with the camera's focal lengths (and a principal point
// shifted to cover the undistorted image), storing inverse eye depth.

layout(location = 0) in vec3 a_position;  // world units

layout(location = 0) uniform mat4 u_clip_from_world;  // pinhole projection (image row r on window row r)
layout(location = 1) uniform mat4 u_cam_from_world;   // OpenCV camera frame, z forward

out float v_depth;  // camera-space z, world units

void main() {
  v_depth = (u_cam_from_world * vec4(a_position, 1.0)).z;
  gl_Position = u_clip_from_world * vec4(a_position, 1.0);
}
