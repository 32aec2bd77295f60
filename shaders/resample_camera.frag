// Per-texel resampling of one camera's frame into the atlas
// (core/resample/resampler.cc): reads the frame's geometry atlas, tests
// facing, the image bounds and the camera's depth map, and samples the frame
// bilinearly at the distorted pixel. Output a = 1 valid, a = 0 invalid.

#include "resample_distortion.glsl"

layout(binding = 0) uniform sampler2D u_position_map;  // RGBA32F: world xyz, w = 1 covered
layout(binding = 1) uniform sampler2D u_normal_map;    // RGBA32F: unit world normal
layout(binding = 2) uniform sampler2D u_depth_map;     // R32F: 1 / eye z of the nearest surface, pinhole, row r = image row, bilinear
layout(binding = 3) uniform sampler2D u_frame;         // RGB32F linear, row 0 = image top, bilinear
layout(binding = 4) uniform isampler2D u_texel_triangle;  // R32I: the texel's drawn triangle (-1: none)
layout(binding = 5) uniform isampler2D u_pixel_triangle;  // R32I, depth-map pixels: drawn triangle (-1: none)
// The posed mesh as drawn, per drawn triangle (indexed by gl_PrimitiveID)
// its three corners: positions (xyz world units, w = 1) and position ids
// (equal ids: equal positions, across UV seams too).
layout(std430, binding = 1) readonly buffer Corners { vec4 u_corners[]; };
layout(std430, binding = 2) readonly buffer CornerIds { uint u_corner_ids[]; };

layout(location = 0) uniform mat4 u_cam_from_world;
// The viewpoint, homogeneous (scene::CameraModel::ViewOrigin): (centre, 1) for
// a pinhole, (unit direction towards the camera, 0) for an orthographic camera.
layout(location = 1) uniform vec4 u_camera_center;    // world units
// fx, fy, cx, cy (pixels; (0,0) = centre of top-left pixel); orthographic:
// fx = fy = 1 / pixel_size.
layout(location = 2) uniform vec4 u_intrinsics;
layout(location = 3) uniform vec2 u_depth_principal;  // cx, cy of the depth map (same focal lengths)
layout(location = 4) uniform vec4 u_distortion_a;     // k1, k2, p1, p2
layout(location = 5) uniform vec4 u_distortion_b;     // k3, k4, k5, k6
layout(location = 6) uniform float u_min_cos_view;    // sin(grazing margin): dot(n, v) must exceed it
layout(location = 7) uniform float u_depth_scale;     // 1 + relative depth tolerance
layout(location = 8) uniform float u_depth_absolute;  // absolute depth tolerance, world units
// The exact occluder test's margin, relative to depth (pinhole); < 0: no
// exact test. Orthographic (depth from an arbitrary plane): world units.
layout(location = 9) uniform float u_occluder_tolerance;
layout(location = 10) uniform float u_occluder_margin_orthographic;
layout(location = 16) uniform int u_orthographic;     // nonzero: (x, y) instead of (x/z, y/z); no distortion

layout(location = 0) out vec4 out_radiance;

// Orthographic: z (not 1 / z) is affine in image coordinates over a plane, so
// interpolate z between the four depth-map pixels around `pixel` (bilinear
// 1 / z would overestimate it on slanted surfaces, by convexity, and make them
// occlude themselves). Where one of them shows no surface, keep `bilinear`.
float OrthographicInverseDepth(vec2 pixel, float bilinear) {
  ivec2 depth_max = textureSize(u_depth_map, 0) - 1;
  vec2 at = clamp(pixel, vec2(0.0), vec2(depth_max));
  ivec2 base = min(ivec2(floor(at)), max(depth_max - 1, ivec2(0)));
  vec2 f = at - vec2(base);
  float d00 = texelFetch(u_depth_map, min(base, depth_max), 0).r;
  float d10 = texelFetch(u_depth_map, min(base + ivec2(1, 0), depth_max), 0).r;
  float d01 = texelFetch(u_depth_map, min(base + ivec2(0, 1), depth_max), 0).r;
  float d11 = texelFetch(u_depth_map, min(base + ivec2(1, 1), depth_max), 0).r;
  if (!(min(min(d00, d10), min(d01, d11)) > 0.0)) return bilinear;
  float z = mix(mix(1.0 / d00, 1.0 / d10, f.x), mix(1.0 / d01, 1.0 / d11, f.x), f.y);
  return 1.0 / z;
}

// Distance along the ray origin + s * direction (unit) at which it crosses
// drawn triangle t (Moller-Trumbore); -1 when it misses.
float RayCrossing(int t, vec3 origin, vec3 direction) {
  uint base = 3u * uint(t);
  vec3 a = u_corners[base].xyz;
  vec3 e1 = u_corners[base + 1u].xyz - a;
  vec3 e2 = u_corners[base + 2u].xyz - a;
  vec3 p = cross(direction, e2);
  float det = dot(e1, p);
  if (abs(det) < 1e-30) return -1.0;  // the ray lies in the triangle's plane
  vec3 o = origin - a;
  float u = dot(o, p) / det;
  if (u < 0.0 || u > 1.0) return -1.0;
  vec3 q = cross(o, e1);
  float v = dot(direction, q) / det;
  if (v < 0.0 || u + v > 1.0) return -1.0;
  return dot(e2, q) / det;
}

// Whether a triangle the camera sees at one of the four depth-map pixels
// around `pinhole` (other than the texel's own) crosses the ray from `point`
// towards the camera (`towards`, unit) further than `margin` in front of it.
bool OccludedExactly(vec2 pinhole, int own, vec3 point, vec3 towards, float margin) {
  ivec2 depth_max = textureSize(u_pixel_triangle, 0) - 1;
  ivec2 base = ivec2(floor(pinhole));
  int tested[4] = int[4](-1, -1, -1, -1);
  for (int k = 0; k < 4; ++k) {
    int t = texelFetch(u_pixel_triangle, clamp(base + ivec2(k & 1, k >> 1), ivec2(0), depth_max), 0).r;
    if (t < 0 || t == own || t == tested[0] || t == tested[1] || t == tested[2]) continue;
    tested[k] = t;
    if (RayCrossing(t, point, towards) > margin) return true;
  }
  return false;
}

// Whether drawn triangle `other` belongs to the surroundings of drawn
// triangle `own`: itself or one sharing a vertex position (across UV seams
// too, where the render vertices are copies).
bool Adjacent(int own, int other) {
  if (own == other) return true;
  uint a = 3u * uint(own), b = 3u * uint(other);
  uvec3 ids = uvec3(u_corner_ids[b], u_corner_ids[b + 1u], u_corner_ids[b + 2u]);
  for (uint i = 0u; i < 3u; ++i) {
    if (any(equal(uvec3(u_corner_ids[a + i]), ids))) return true;
  }
  return false;
}

// Whether depth-map pixel `d` shows another part of the mesh in front of the
// texel's tangent plane (point `q`, normal `nc`, camera frame): its colour
// belongs to that part (an occluder's edge, the line where two parts
// interpenetrate). The texel's own triangle and its neighbours never count
// (a crease's neighbour lies in front of the plane but is the same surface).
bool ShowsAnotherPartInFront(ivec2 d, int own, vec3 q, vec3 nc, float margin) {
  int t = texelFetch(u_pixel_triangle, d, 0).r;
  if (t < 0 || own < 0 || t == own) return false;
  vec2 xy = (vec2(d) - u_depth_principal) / u_intrinsics.xy;
  vec3 origin = u_orthographic != 0 ? vec3(xy, 0.0) : vec3(0.0);
  vec3 direction = u_orthographic != 0 ? vec3(0.0, 0.0, 1.0) : vec3(xy, 1.0);
  float slope = dot(nc, direction);
  if (!(slope < -1e-3 * length(direction))) return false;  // the plane is edge-on there
  float plane_z = dot(nc, q - origin) / slope;
  float pixel_z = 1.0 / texelFetch(u_depth_map, d, 0).r;
  // The neighbour test last: it reads both triangles' vertices.
  return pixel_z < plane_z - margin && !Adjacent(own, t);
}

void main() {
  out_radiance = vec4(0.0);
  ivec2 texel = ivec2(gl_FragCoord.xy);
  vec4 position = texelFetch(u_position_map, texel, 0);
  if (position.w < 0.5) return;  // uncovered
  vec3 n = texelFetch(u_normal_map, texel, 0).xyz;
  vec3 v = normalize(u_camera_center.xyz - u_camera_center.w * position.xyz);
  if (!(dot(n, v) > u_min_cos_view)) return;  // back-facing or grazing

  vec3 q = (u_cam_from_world * vec4(position.xyz, 1.0)).xyz;
  if (!(q.z > 0.0)) return;  // behind the camera
  vec2 undistorted = u_orthographic != 0 ? q.xy : q.xy / q.z;

  // Visibility: the depth map (inverse depth, bilinear: exact on the point's
  // own triangle, so slanted surfaces do not occlude themselves) at the
  // pinhole projection. Occluded when z > (1 + relative) * z_map + absolute;
  // within that, when a triangle seen there crosses the texel's ray in front
  // of it (ResamplerOptions::exact_occluder_test).
  vec2 pinhole = u_intrinsics.xy * undistorted + u_depth_principal;
  vec2 depth_size = vec2(textureSize(u_depth_map, 0));
  if (any(lessThan(pinhole, vec2(-0.5))) || any(greaterThan(pinhole, depth_size - 0.5))) {
    return;  // outside the undistorted field of view (also rejects distortion fold-over)
  }
  float inverse_depth = textureLod(u_depth_map, (pinhole + 0.5) / depth_size, 0.0).r;
  if (u_orthographic != 0) inverse_depth = OrthographicInverseDepth(pinhole, inverse_depth);
  if (q.z * inverse_depth > u_depth_scale + u_depth_absolute * inverse_depth) return;  // occluded
  // The exact test also where the bilinear map passed the texel by a wide
  // margin: at an occluder's silhouette it mixes the occluder's depth with
  // that of the surface behind it.
  int own = texelFetch(u_texel_triangle, texel, 0).r;
  float margin = u_orthographic != 0 ? u_occluder_margin_orthographic : u_occluder_tolerance * q.z;
  if (u_occluder_tolerance >= 0.0 && OccludedExactly(pinhole, own, position.xyz, v, margin)) {
    return;  // inside or behind another part, nearer than the tolerance
  }

  // Sampling: the distorted pixel, inside [0, w-1] x [0, h-1] so that the
  // bilinear footprint stays inside the image.
  vec2 pixel = u_intrinsics.xy * DistortNormalized(undistorted, u_distortion_a, u_distortion_b) + u_intrinsics.zw;
  vec2 size = vec2(textureSize(u_frame, 0));
  if (any(lessThan(pixel, vec2(0.0))) || any(greaterThan(pixel, size - 1.0))) return;

  // Bilinear interpolation over the pixels of the 2x2 footprint that show the
  // mesh, with renormalised weights. At silhouettes this is the thesis's
  // "frame grown outwards at the edges" (§5): background pixels never leak
  // into the surface's samples. A pixel shows the mesh when the depth map has
  // a surface at its pinhole position (the distortion is taken as locally a
  // translation between the distorted and the pinhole positions).
  ivec2 base = ivec2(floor(pixel));
  vec2 f = pixel - vec2(base);
  ivec2 frame_max = ivec2(size) - 1;
  ivec2 depth_max = ivec2(depth_size) - 1;
  vec3 nc = mat3(u_cam_from_world) * n;  // the texel's normal, camera frame
  vec3 sum = vec3(0.0);
  float weight = 0.0;
  float invalid = 0.0;  // a pixel's mark (< 0: masked or saturated, core/scene/video_source.h)
  for (int k = 0; k < 4; ++k) {
    ivec2 offset = ivec2(k & 1, k >> 1);
    ivec2 p = min(base + offset, frame_max);
    ivec2 d = clamp(ivec2(round(pinhole + vec2(p) - pixel)), ivec2(0), depth_max);
    if (texelFetch(u_depth_map, d, 0).r <= 0.0) continue;
    if (u_occluder_tolerance >= 0.0 && ShowsAnotherPartInFront(d, own, q, nc, margin)) continue;
    float w = (offset.x == 1 ? f.x : 1.0 - f.x) * (offset.y == 1 ? f.y : 1.0 - f.y);
    vec3 rgb = texelFetch(u_frame, p, 0).rgb;
    if (rgb.r < 0.0 && w > 0.0) invalid = rgb.r;
    sum += w * rgb;
    weight += w;
  }
  // A texel whose footprint is almost all background sits outside the
  // silhouette as the camera sees it: no reliable sample.
  if (weight < 0.25) return;
  if (invalid < 0.0) {
    out_radiance = vec4(0.0, 0.0, 0.0, invalid);  // refused: counted by the resampler
    return;
  }
  out_radiance = vec4(sum / weight, 1.0);
}
