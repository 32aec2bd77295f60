#include "core/resample/resampler.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <glm/gtc/type_ptr.hpp>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <unordered_map>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/gl/gl_api.h"
#include "core/gl/gl_objects.h"
#include "core/gl/shader_program.h"
#include "core/render/camera_projection.h"
#include "core/render/shadow_maps.h"
#include "core/scene/video_source.h"

namespace mvbrdf::resample {
namespace {

uint32_t FloatBits(float f) {
  uint32_t bits;
  std::memcpy(&bits, &f, sizeof(bits));
  return bits;
}

struct PositionBitsHash {
  size_t operator()(const std::array<uint32_t, 3>& key) const {
    uint64_t h = 1469598103934665603ull;
    for (uint32_t k : key) h = (h ^ k) * 1099511628211ull;
    return static_cast<size_t>(h ^ (h >> 29));
  }
};

// Lights per shadow pass (shaders/resample_shadow.frag kMaxLights): one
// 16-bit channel of the shadow atlas, light k at bit k % 16 of channel k / 16.
constexpr int kLightsPerPass = 16;

// Vertex attributes (shaders/resample_geometry.vert, resample_depth.vert and
// render::ShadowMaps's shadow.vert all read the position at location 0).
constexpr GLuint kPositionAttribute = 0;
constexpr GLuint kNormalAttribute = 1;
constexpr GLuint kUvAttribute = 2;

// Uniform locations (layout(location = ...) in the shaders).
constexpr GLint kDepthClipFromWorld = 0;  // resample_depth.vert
constexpr GLint kDepthCamFromWorld = 1;
constexpr GLint kDepthAtlasSize = 8;  // resample_depth.frag
constexpr GLint kCamFromWorld = 0;  // resample_camera.frag
constexpr GLint kCameraCenter = 1;
constexpr GLint kIntrinsics = 2;
constexpr GLint kDepthPrincipal = 3;
constexpr GLint kDistortionA = 4;
constexpr GLint kDistortionB = 5;
constexpr GLint kMinCosView = 6;
constexpr GLint kDepthScale = 7;
constexpr GLint kDepthAbsolute = 8;
constexpr GLint kOccluderTolerance = 9;
constexpr GLint kOccluderMarginOrthographic = 10;
constexpr GLint kOrthographic = 16;

// Texture units of the full-screen passes.
constexpr GLuint kPositionMapUnit = 0;
constexpr GLuint kNormalMapUnit = 1;
constexpr GLuint kDepthMapUnit = 2;  // resample_camera.frag
constexpr GLuint kFrameUnit = 3;
constexpr GLuint kTexelTriangleUnit = 4;  // resample_camera.frag
constexpr GLuint kPixelTriangleUnit = 5;
constexpr GLuint kCornersBinding = 1;  // resample_camera.frag's storage buffers
constexpr GLuint kCornerIdsBinding = 2;
// The exact occluder test's margin, relative to the texel's depth (for an
// orthographic camera, to the pose's extent from the origin): above float
// rounding of positions and intersections (~1e-6), far below the depth map's
// tolerance.
constexpr double kOccluderRelativeTolerance = 1e-4;
constexpr GLuint kPointShadowUnit = 2;  // resample_shadow.frag
constexpr GLuint kDirectionalShadowUnit = 3;
constexpr GLuint kShadowLightBlockBinding = 0;

// std140 mirror of GpuShadowLight in shaders/resample_shadow.frag.
struct GpuShadowLight {
  glm::vec4 position;
  glm::vec4 shadow;
  glm::mat4 shadow_from_world;
};
static_assert(sizeof(GpuShadowLight) == 96, "std140 layout of GpuShadowLight");

struct GpuShadowLightBlock {
  glm::ivec4 count;
  GpuShadowLight lights[kLightsPerPass];
};

// The camera's depth map: an undistorted pinhole with the camera's focal
// lengths whose pixel grid is the camera's shifted by an integer offset, large
// enough to hold the pinhole projection of every point whose distorted pixel
// lies in the image (barrel distortion pushes the undistorted image corners
// outwards). Without distortion it is the camera's own grid.
struct DepthMapLayout {
  int width = 0;
  int height = 0;
  double cx = 0.0, cy = 0.0;  // principal point in depth-map pixels
};

DepthMapLayout ComputeDepthMapLayout(const scene::CameraModel& camera, int max_size) {
  if (!camera.has_distortion()) return {camera.width, camera.height, camera.cx, camera.cy};
  // Undistort points along the image border (pixel edges) and take the
  // bounding box of their pinhole pixels.
  constexpr int kSamplesPerSide = 256;
  double lo_x = std::numeric_limits<double>::max(), lo_y = lo_x;
  double hi_x = std::numeric_limits<double>::lowest(), hi_y = hi_x;
  auto add = [&](double px, double py) {
    const glm::dvec2 u = camera.Undistort({(px - camera.cx) / camera.fx, (py - camera.cy) / camera.fy});
    const double x = camera.fx * u.x + camera.cx, y = camera.fy * u.y + camera.cy;
    if (!std::isfinite(x) || !std::isfinite(y)) return;
    lo_x = std::min(lo_x, x);
    hi_x = std::max(hi_x, x);
    lo_y = std::min(lo_y, y);
    hi_y = std::max(hi_y, y);
  };
  const double x0 = -0.5, x1 = camera.width - 0.5, y0 = -0.5, y1 = camera.height - 0.5;
  for (int i = 0; i <= kSamplesPerSide; ++i) {
    const double s = static_cast<double>(i) / kSamplesPerSide;
    add(x0 + s * (x1 - x0), y0);
    add(x0 + s * (x1 - x0), y1);
    add(x0, y0 + s * (y1 - y0));
    add(x1, y0 + s * (y1 - y0));
  }
  if (!(lo_x <= hi_x) || !(lo_y <= hi_y)) return {camera.width, camera.height, camera.cx, camera.cy};
  // One pixel of margin; crop (pathological distortion) to at most twice the
  // image around it, and to the GL limit. Points projecting outside the map
  // are treated as invalid by the resampling pass.
  int ox = static_cast<int>(std::floor(lo_x)) - 1, oy = static_cast<int>(std::floor(lo_y)) - 1;
  int ex = static_cast<int>(std::ceil(hi_x)) + 2, ey = static_cast<int>(std::ceil(hi_y)) + 2;
  ox = std::max(ox, -camera.width / 2);
  oy = std::max(oy, -camera.height / 2);
  ex = std::min({ex, camera.width + camera.width / 2, ox + max_size});
  ey = std::min({ey, camera.height + camera.height / 2, oy + max_size});
  return {ex - ox, ey - oy, camera.cx - ox, camera.cy - oy};
}

// A 2D texture for texelFetch/bilinear lookups, clamped at the border.
gl::Texture CreateTexture2D(GLenum internal_format, int width, int height, GLint filter) {
  gl::Texture texture = gl::CreateTexture(GL_TEXTURE_2D);
  glTextureStorage2D(texture.id(), 1, internal_format, width, height);
  glTextureParameteri(texture.id(), GL_TEXTURE_MIN_FILTER, filter);
  glTextureParameteri(texture.id(), GL_TEXTURE_MAG_FILTER, filter);
  glTextureParameteri(texture.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(texture.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return texture;
}

absl::Status CheckCamera(const scene::CameraModel& camera, size_t index) {
  const std::string field = absl::StrCat("cameras[", index, "] (\"", camera.name, "\")");
  if (camera.width <= 0 || camera.height <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".width, height: must be > 0, got ", camera.width, "x", camera.height));
  }
  if (camera.orthographic()) {
    if (!(camera.pixel_size > 0.0) || !std::isfinite(camera.pixel_size)) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ".pixel_size: must be finite and > 0, got ", camera.pixel_size));
    }
    if (camera.has_distortion()) {
      return absl::InvalidArgumentError(absl::StrCat(field, ".distortion: an orthographic camera has none"));
    }
  } else if (!(camera.fx > 0.0) || !(camera.fy > 0.0) || !std::isfinite(camera.fx) || !std::isfinite(camera.fy)) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".fx, fy: must be finite and > 0, got ", camera.fx, ", ", camera.fy));
  }
  if (!std::isfinite(camera.cx) || !std::isfinite(camera.cy)) {
    return absl::InvalidArgumentError(absl::StrCat(field, ".cx, cy: must be finite"));
  }
  if (camera.distortion.size() > 8) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".distortion: at most 8 coefficients, got ", camera.distortion.size()));
  }
  for (double d : camera.distortion) {
    if (!std::isfinite(d)) return absl::InvalidArgumentError(absl::StrCat(field, ".distortion: must be finite"));
  }
  return absl::OkStatus();
}

// Whether Surface(camera) carries the triangle maps (CameraSurface).
bool HasTriangleMaps(const scene::CameraModel& camera, const ResamplerOptions& options) {
  return camera.has_distortion() || (options.surface_triangles && !camera.orthographic());
}

// Per camera: its depth map for the current frame (rendered lazily by the
// first ResampleCamera of the frame) and the texture its frames are uploaded to.
struct CameraState {
  scene::CameraModel model;  // distortion padded to 8 coefficients
  DepthMapLayout layout;
  gl::Texture depth_map;          // R32F, layout size: 1 / eye z of the nearest surface (1 / world units)
  gl::Renderbuffer depth_buffer;  // DEPTH_COMPONENT32F, for the nearest-surface test only
  gl::Framebuffer depth_framebuffer;
  gl::Texture surface_position;  // RGBA32F, layout size: world xyz, w = atlas texel + 1 (0: none)
  gl::Texture surface_normal;    // RGBA32F, layout size: unit world normal
  gl::Texture surface_triangle;  // R32I, layout size: drawn triangle under the pixel centre (-1: none)
  gl::Texture frame_texture;  // RGB32F at the camera size, bilinear
  uint64_t depth_frame = 0;   // the frame number the depth map belongs to (0: none)
  Resampler::RefusedObservations refused;
};

}  // namespace

struct Resampler::Impl {
  gl::EglContext* context = nullptr;
  ResamplerOptions options;
  int size = 0;  // atlas texels per side
  scene::MeshTopology topology;
  std::vector<scene::Light> lights;
  GLsizei num_indices = 0;  // of the triangles with non-zero rest-pose area
  GLint max_texture_size = 0;

  gl::VertexArray mesh_vertex_array;
  gl::VertexArray empty_vertex_array;  // for the full-screen passes (core profile needs one bound)
  gl::Buffer position_buffer;          // per render vertex, per frame
  gl::Buffer normal_buffer;            // per render vertex, per frame
  gl::Buffer uv_buffer;
  gl::Buffer index_buffer;
  // Per drawn triangle its three corners as the exact occluder test reads
  // them (resample_camera.frag), per frame: posed positions (vec4, w = 1),
  // and position ids (uint; equal ids: equal positions this frame).
  gl::Buffer corner_buffer;
  gl::Buffer corner_id_buffer;
  std::vector<glm::uvec3> drawn;  // the drawn triangles, render vertices
  // The current frame's drawn triangles for the surfaces that carry them
  // (CameraSurface::triangles); null when none does.
  std::shared_ptr<const std::vector<SurfaceTriangle>> surface_triangles;
  bool any_triangle_maps = false;
  gl::Buffer light_buffer;  // GpuShadowLightBlock

  gl::Program geometry_program;
  gl::Program depth_program;
  gl::Program camera_program;
  gl::Program shadow_atlas_program;

  // Geometry atlas: RGBA32F textures, GL row r = atlas image row r.
  gl::Texture position_map;
  gl::Texture normal_map;
  gl::Texture triangle_map;  // R32I: drawn triangle per texel (-1: none)
  gl::Framebuffer geometry_framebuffer;

  gl::Renderbuffer resample_target;  // RGBA32F
  gl::Framebuffer resample_framebuffer;
  gl::Renderbuffer shadow_target;  // R16UI
  gl::Framebuffer shadow_atlas_framebuffer;

  // The renderer's shadow maps (same maps, same lookups); null without lights.
  std::unique_ptr<render::ShadowMaps> shadow_maps;

  std::vector<CameraState> cameras;

  // Frames are numbered from 1 by SetFrame; 0 means none yet.
  uint64_t frame = 0;
  render::BoundingSphere bounds;  // of the current pose
  uint64_t shadow_frame = 0;
  cv::Mat shadow_atlas;             // CV_16UC(channels) of shadow_frame
  std::vector<bool> shadow_lights;  // the lights computed in shadow_atlas

  absl::Status CheckReady(absl::string_view what) const {
    if (!context->IsCurrent()) {
      return absl::FailedPreconditionError(absl::StrCat(what, ": the EGL context is not current on this thread"));
    }
    if (frame == 0) return absl::FailedPreconditionError(absl::StrCat(what, ": call SetFrame first"));
    return absl::OkStatus();
  }
  void DrawMesh() const {
    glBindVertexArray(mesh_vertex_array.id());
    if (num_indices > 0) glDrawElements(GL_TRIANGLES, num_indices, GL_UNSIGNED_INT, nullptr);
  }
  void DrawFullScreen() const {
    glBindVertexArray(empty_vertex_array.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
  }
  absl::Status RenderGeometry();
  absl::Status EnsureDepthMap(CameraState& camera);
  absl::Status UploadFrame(CameraState& camera, const cv::Mat& frame_rgb);
  // Reads the bound read framebuffer's `attachment` (size x size) into `out`.
  void ReadAtlas(GLuint framebuffer, GLenum attachment, GLenum format, GLenum type, cv::Mat* out) const;
};

Resampler::Resampler(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Resampler::~Resampler() = default;

absl::StatusOr<std::unique_ptr<Resampler>> Resampler::Create(gl::EglContext& context, const atlas::Atlas& atlas,
                                                             const std::vector<scene::CameraModel>& cameras,
                                                             const std::vector<scene::Light>& lights,
                                                             const ResamplerOptions& options) {
  if (!context.IsCurrent()) {
    return absl::FailedPreconditionError("Resampler::Create: the EGL context is not current on this thread");
  }
  if (!(options.grazing_margin_deg >= 0.0) || !(options.grazing_margin_deg < 90.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("options.grazing_margin_deg: must be in [0, 90), got ", options.grazing_margin_deg));
  }
  if (!(options.relative_depth_tolerance >= 0.0) || !std::isfinite(options.relative_depth_tolerance)) {
    return absl::InvalidArgumentError(absl::StrCat("options.relative_depth_tolerance: must be finite and >= 0, got ",
                                                   options.relative_depth_tolerance));
  }
  if (!(options.absolute_depth_tolerance >= 0.0) || !std::isfinite(options.absolute_depth_tolerance)) {
    return absl::InvalidArgumentError(absl::StrCat("options.absolute_depth_tolerance: must be finite and >= 0, got ",
                                                   options.absolute_depth_tolerance));
  }
  if (options.shadow_map_size < 1 || options.shadow_map_size > 8192) {
    return absl::InvalidArgumentError(
        absl::StrCat("options.shadow_map_size: must be in [1, 8192], got ", options.shadow_map_size));
  }
  const scene::MeshTopology& topo = atlas.topology;
  const size_t n = topo.num_render_vertices();
  if (!topo.has_uvs() || topo.uvs.size() != n) {
    return absl::InvalidArgumentError(
        absl::StrCat("atlas.topology.uvs: expected one per render vertex (", n, "), got ", topo.uvs.size()));
  }
  if (n == 0 || topo.triangles.empty()) return absl::InvalidArgumentError("atlas.topology: no triangles");
  if (topo.file_triangles.size() != topo.triangles.size()) {
    return absl::InvalidArgumentError(absl::StrCat("atlas.topology.file_triangles: expected ", topo.triangles.size(),
                                                   " (one per triangle), got ", topo.file_triangles.size()));
  }
  for (size_t v = 0; v < n; ++v) {
    if (topo.render_to_file_vertex[v] >= topo.num_file_vertices) {
      return absl::InvalidArgumentError(absl::StrCat("atlas.topology.render_to_file_vertex[", v,
                                                     "]: ", topo.render_to_file_vertex[v], " >= num_file_vertices ",
                                                     topo.num_file_vertices));
    }
  }
  for (size_t t = 0; t < topo.triangles.size(); ++t) {
    const glm::uvec3& tri = topo.triangles[t];
    const glm::uvec3& ftri = topo.file_triangles[t];
    if (tri.x >= n || tri.y >= n || tri.z >= n) {
      return absl::InvalidArgumentError(absl::StrCat("atlas.topology.triangles[", t, "]: vertex index out of range (",
                                                     tri.x, ", ", tri.y, ", ", tri.z, "), ", n, " render vertices"));
    }
    const uint32_t nf = topo.num_file_vertices;
    if (ftri.x >= nf || ftri.y >= nf || ftri.z >= nf) {
      return absl::InvalidArgumentError(
          absl::StrCat("atlas.topology.file_triangles[", t, "]: vertex index out of range, ", nf, " file vertices"));
    }
  }
  for (size_t k = 0; k < lights.size(); ++k) {
    if (lights[k].directional && !(glm::length(lights[k].direction) > 0.0f)) {
      return absl::InvalidArgumentError(absl::StrCat("lights[", k, "] (\"", lights[k].name,
                                                     "\").direction: must be non-zero for a directional light"));
    }
  }
  for (size_t c = 0; c < cameras.size(); ++c) MVBRDF_RETURN_IF_ERROR(CheckCamera(cameras[c], c));

  auto impl = std::make_unique<Impl>();
  Impl& r = *impl;
  r.context = &context;
  r.options = options;
  r.size = atlas.size;
  r.topology = topo;
  r.lights = lights;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &r.max_texture_size);
  if (atlas.size < 1 || atlas.size > r.max_texture_size) {
    return absl::InvalidArgumentError(
        absl::StrCat("atlas.size: must be in [1, ", r.max_texture_size, "] (GL_MAX_TEXTURE_SIZE), got ", atlas.size));
  }

  // Triangles with zero rest-pose area are excluded from resampling
  // (core/scene/mesh.h): they are neither drawn into the atlas nor cast shadows.
  std::vector<uint8_t> skip(topo.triangles.size(), 0);
  for (uint32_t t : topo.zero_area_triangles) {
    if (t < skip.size()) skip[t] = 1;
  }
  std::vector<glm::uvec3> drawn;
  drawn.reserve(topo.triangles.size());
  for (size_t t = 0; t < topo.triangles.size(); ++t) {
    if (!skip[t]) drawn.push_back(topo.triangles[t]);
  }
  r.num_indices = static_cast<GLsizei>(drawn.size() * 3);
  r.drawn = drawn;

  MVBRDF_ASSIGN_OR_RETURN(r.geometry_program, gl::BuildProgram({{GL_VERTEX_SHADER, "resample_geometry.vert", {}},
                                                                {GL_FRAGMENT_SHADER, "resample_geometry.frag", {}}}));
  MVBRDF_ASSIGN_OR_RETURN(r.depth_program, gl::BuildProgram({{GL_VERTEX_SHADER, "resample_depth.vert", {}},
                                                             {GL_FRAGMENT_SHADER, "resample_depth.frag", {}}}));
  MVBRDF_ASSIGN_OR_RETURN(r.camera_program, gl::BuildProgram({{GL_VERTEX_SHADER, "resample_fullscreen.vert", {}},
                                                              {GL_FRAGMENT_SHADER, "resample_camera.frag", {}}}));
  MVBRDF_ASSIGN_OR_RETURN(r.shadow_atlas_program, gl::BuildProgram({{GL_VERTEX_SHADER, "resample_fullscreen.vert", {}},
                                                                    {GL_FRAGMENT_SHADER, "resample_shadow.frag", {}}}));

  // Mesh: positions and normals change per frame, UVs and indices do not.
  const GLsizeiptr vec3_bytes = static_cast<GLsizeiptr>(n * sizeof(glm::vec3));
  r.position_buffer = gl::CreateBuffer();
  glNamedBufferStorage(r.position_buffer.id(), vec3_bytes, nullptr, GL_DYNAMIC_STORAGE_BIT);
  r.normal_buffer = gl::CreateBuffer();
  glNamedBufferStorage(r.normal_buffer.id(), vec3_bytes, nullptr, GL_DYNAMIC_STORAGE_BIT);
  r.uv_buffer = gl::CreateBuffer();
  glNamedBufferStorage(r.uv_buffer.id(), static_cast<GLsizeiptr>(n * sizeof(glm::vec2)), topo.uvs.data(), 0);
  r.index_buffer = gl::CreateBuffer();
  glNamedBufferStorage(r.index_buffer.id(),
                       static_cast<GLsizeiptr>(std::max<size_t>(drawn.size(), 1) * sizeof(glm::uvec3)),
                       drawn.empty() ? nullptr : drawn.data(), 0);
  r.corner_buffer = gl::CreateBuffer();
  glNamedBufferStorage(r.corner_buffer.id(),
                       static_cast<GLsizeiptr>(std::max<size_t>(drawn.size(), 1) * 3 * sizeof(glm::vec4)), nullptr,
                       GL_DYNAMIC_STORAGE_BIT);
  r.corner_id_buffer = gl::CreateBuffer();
  glNamedBufferStorage(r.corner_id_buffer.id(),
                       static_cast<GLsizeiptr>(std::max<size_t>(drawn.size(), 1) * 3 * sizeof(uint32_t)), nullptr,
                       GL_DYNAMIC_STORAGE_BIT);
  r.mesh_vertex_array = gl::CreateVertexArray();
  const GLuint vao = r.mesh_vertex_array.id();
  glVertexArrayVertexBuffer(vao, 0, r.position_buffer.id(), 0, sizeof(glm::vec3));
  glVertexArrayVertexBuffer(vao, 1, r.normal_buffer.id(), 0, sizeof(glm::vec3));
  glVertexArrayVertexBuffer(vao, 2, r.uv_buffer.id(), 0, sizeof(glm::vec2));
  const GLuint attributes[3] = {kPositionAttribute, kNormalAttribute, kUvAttribute};
  const GLint components[3] = {3, 3, 2};
  for (GLuint i = 0; i < 3; ++i) {
    glEnableVertexArrayAttrib(vao, attributes[i]);
    glVertexArrayAttribFormat(vao, attributes[i], components[i], GL_FLOAT, GL_FALSE, 0);
    glVertexArrayAttribBinding(vao, attributes[i], i);
  }
  glVertexArrayElementBuffer(vao, r.index_buffer.id());
  r.empty_vertex_array = gl::CreateVertexArray();
  MVBRDF_RETURN_IF_ERROR(gl::CheckGlError("Resampler::Create: mesh buffers"));

  // Atlas targets.
  r.position_map = CreateTexture2D(GL_RGBA32F, r.size, r.size, GL_NEAREST);
  r.normal_map = CreateTexture2D(GL_RGBA32F, r.size, r.size, GL_NEAREST);
  r.geometry_framebuffer = gl::CreateFramebuffer();
  glNamedFramebufferTexture(r.geometry_framebuffer.id(), GL_COLOR_ATTACHMENT0, r.position_map.id(), 0);
  glNamedFramebufferTexture(r.geometry_framebuffer.id(), GL_COLOR_ATTACHMENT1, r.normal_map.id(), 0);
  r.triangle_map = CreateTexture2D(GL_R32I, r.size, r.size, GL_NEAREST);
  glNamedFramebufferTexture(r.geometry_framebuffer.id(), GL_COLOR_ATTACHMENT2, r.triangle_map.id(), 0);
  const GLenum geometry_buffers[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
  glNamedFramebufferDrawBuffers(r.geometry_framebuffer.id(), 3, geometry_buffers);
  MVBRDF_RETURN_IF_ERROR(gl::CheckFramebufferComplete(r.geometry_framebuffer, "geometry atlas target"));

  r.resample_target = gl::CreateRenderbuffer();
  glNamedRenderbufferStorage(r.resample_target.id(), GL_RGBA32F, r.size, r.size);
  r.resample_framebuffer = gl::CreateFramebuffer();
  glNamedFramebufferRenderbuffer(r.resample_framebuffer.id(), GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER,
                                 r.resample_target.id());
  glNamedFramebufferDrawBuffer(r.resample_framebuffer.id(), GL_COLOR_ATTACHMENT0);
  MVBRDF_RETURN_IF_ERROR(gl::CheckFramebufferComplete(r.resample_framebuffer, "resampled atlas target"));

  r.shadow_target = gl::CreateRenderbuffer();
  glNamedRenderbufferStorage(r.shadow_target.id(), GL_R16UI, r.size, r.size);
  r.shadow_atlas_framebuffer = gl::CreateFramebuffer();
  glNamedFramebufferRenderbuffer(r.shadow_atlas_framebuffer.id(), GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER,
                                 r.shadow_target.id());
  glNamedFramebufferDrawBuffer(r.shadow_atlas_framebuffer.id(), GL_COLOR_ATTACHMENT0);
  MVBRDF_RETURN_IF_ERROR(gl::CheckFramebufferComplete(r.shadow_atlas_framebuffer, "shadow atlas target"));

  // Shadow maps: allocated and rendered lazily, the arrays growing to the
  // largest pass drawn (a frame of a one-light-at-a-time capture draws one
  // light, not the first pass's sixteen).
  if (!lights.empty()) {
    MVBRDF_ASSIGN_OR_RETURN(r.shadow_maps, render::ShadowMaps::Create(options.shadow_map_size));
    r.light_buffer = gl::CreateBuffer();
    glNamedBufferStorage(r.light_buffer.id(), sizeof(GpuShadowLightBlock), nullptr, GL_DYNAMIC_STORAGE_BIT);
    MVBRDF_RETURN_IF_ERROR(gl::CheckGlError("Resampler::Create: shadow maps"));
  }

  // Cameras: depth maps sized by their layout; frame textures on first use.
  for (size_t c = 0; c < cameras.size(); ++c) {
    CameraState state;
    state.model = cameras[c];
    state.model.distortion.resize(8, 0.0);
    if (HasTriangleMaps(state.model, options)) r.any_triangle_maps = true;
    state.layout = ComputeDepthMapLayout(state.model, r.max_texture_size);
    if (state.model.width > r.max_texture_size || state.model.height > r.max_texture_size) {
      return absl::InvalidArgumentError(absl::StrCat("cameras[", c, "]: image ", state.model.width, "x",
                                                     state.model.height, " exceeds GL_MAX_TEXTURE_SIZE ",
                                                     r.max_texture_size));
    }
    state.depth_map = CreateTexture2D(GL_R32F, state.layout.width, state.layout.height, GL_LINEAR);
    state.depth_buffer = gl::CreateRenderbuffer();
    glNamedRenderbufferStorage(state.depth_buffer.id(), GL_DEPTH_COMPONENT32F, state.layout.width, state.layout.height);
    state.depth_framebuffer = gl::CreateFramebuffer();
    state.surface_position = CreateTexture2D(GL_RGBA32F, state.layout.width, state.layout.height, GL_NEAREST);
    state.surface_normal = CreateTexture2D(GL_RGBA32F, state.layout.width, state.layout.height, GL_NEAREST);
    state.surface_triangle = CreateTexture2D(GL_R32I, state.layout.width, state.layout.height, GL_NEAREST);
    glNamedFramebufferTexture(state.depth_framebuffer.id(), GL_COLOR_ATTACHMENT0, state.depth_map.id(), 0);
    glNamedFramebufferTexture(state.depth_framebuffer.id(), GL_COLOR_ATTACHMENT1, state.surface_position.id(), 0);
    glNamedFramebufferTexture(state.depth_framebuffer.id(), GL_COLOR_ATTACHMENT2, state.surface_normal.id(), 0);
    glNamedFramebufferTexture(state.depth_framebuffer.id(), GL_COLOR_ATTACHMENT3, state.surface_triangle.id(), 0);
    glNamedFramebufferRenderbuffer(state.depth_framebuffer.id(), GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER,
                                   state.depth_buffer.id());
    const GLenum depth_draw_buffers[4] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2,
                                          GL_COLOR_ATTACHMENT3};
    glNamedFramebufferDrawBuffers(state.depth_framebuffer.id(), 4, depth_draw_buffers);
    MVBRDF_RETURN_IF_ERROR(
        gl::CheckFramebufferComplete(state.depth_framebuffer, absl::StrCat("depth map of cameras[", c, "]")));
    r.cameras.push_back(std::move(state));
  }
  MVBRDF_RETURN_IF_ERROR(gl::CheckGlError("Resampler::Create"));
  return std::unique_ptr<Resampler>(new Resampler(std::move(impl)));
}

absl::Status Resampler::SetFrame(const scene::FramePositions& file_positions) {
  Impl& r = *impl_;
  if (!r.context->IsCurrent()) {
    return absl::FailedPreconditionError("Resampler::SetFrame: the EGL context is not current on this thread");
  }
  if (file_positions.size() != r.topology.num_file_vertices) {
    return absl::InvalidArgumentError(absl::StrCat("file_positions: expected ", r.topology.num_file_vertices,
                                                   " (one per file vertex), got ", file_positions.size()));
  }
  for (size_t v = 0; v < file_positions.size(); ++v) {
    const glm::vec3& p = file_positions[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      return absl::InvalidArgumentError(absl::StrCat("file_positions[", v, "]: not finite"));
    }
  }
  const std::vector<glm::vec3> file_normals = scene::ComputeFileVertexNormals(r.topology, file_positions);
  const std::vector<glm::vec3> positions = scene::ToRenderVertices(r.topology, file_positions);
  const std::vector<glm::vec3> normals = scene::ToRenderVertices(r.topology, file_normals);
  const GLsizeiptr vec3_bytes = static_cast<GLsizeiptr>(positions.size() * sizeof(glm::vec3));
  glNamedBufferSubData(r.position_buffer.id(), 0, vec3_bytes, positions.data());
  glNamedBufferSubData(r.normal_buffer.id(), 0, vec3_bytes, normals.data());
  if (!r.drawn.empty()) {
    // Position ids: render vertices at the same position (copies of a file
    // vertex across UV seams, coincident file vertices) share one.
    std::vector<uint32_t> file_id(file_positions.size());
    {
      std::unordered_map<std::array<uint32_t, 3>, uint32_t, PositionBitsHash> ids;
      ids.reserve(file_positions.size());
      for (size_t v = 0; v < file_positions.size(); ++v) {
        const glm::vec3& p = file_positions[v];
        // +0 and -0 compare equal as floats (as the shader's == did).
        std::array<uint32_t, 3> key;
        for (int i = 0; i < 3; ++i) key[static_cast<size_t>(i)] = FloatBits(p[i] == 0.0f ? 0.0f : p[i]);
        file_id[v] = ids.emplace(key, static_cast<uint32_t>(ids.size())).first->second;
      }
    }
    std::vector<glm::vec4> corners(r.drawn.size() * 3);
    std::vector<uint32_t> corner_ids(r.drawn.size() * 3);
    for (size_t t = 0; t < r.drawn.size(); ++t) {
      for (int i = 0; i < 3; ++i) {
        const uint32_t v = r.drawn[t][i];
        corners[3 * t + static_cast<size_t>(i)] = glm::vec4(positions[v], 1.0f);
        corner_ids[3 * t + static_cast<size_t>(i)] = file_id[r.topology.render_to_file_vertex[v]];
      }
    }
    glNamedBufferSubData(r.corner_buffer.id(), 0, static_cast<GLsizeiptr>(corners.size() * sizeof(glm::vec4)),
                         corners.data());
    glNamedBufferSubData(r.corner_id_buffer.id(), 0, static_cast<GLsizeiptr>(corner_ids.size() * sizeof(uint32_t)),
                         corner_ids.data());
  }
  if (r.any_triangle_maps) {
    auto triangles = std::make_shared<std::vector<SurfaceTriangle>>(r.drawn.size());
    for (size_t t = 0; t < r.drawn.size(); ++t) {
      for (int i = 0; i < 3; ++i) {
        (*triangles)[t].position[i] = positions[r.drawn[t][i]];
        (*triangles)[t].normal[i] = normals[r.drawn[t][i]];
      }
    }
    r.surface_triangles = std::move(triangles);
  }
  r.bounds = render::ComputeBoundingSphere(positions);
  // A new frame number invalidates every camera's depth map and the shadow atlas.
  ++r.frame;
  r.shadow_atlas.release();
  return r.RenderGeometry();
}

absl::Status Resampler::Impl::RenderGeometry() {
  glBindFramebuffer(GL_FRAMEBUFFER, geometry_framebuffer.id());
  glViewport(0, 0, size, size);
  glDisable(GL_DEPTH_TEST);  // a valid atlas has no overlapping triangles
  glDisable(GL_CULL_FACE);
  glDisable(GL_BLEND);
  glDisable(GL_COLOR_LOGIC_OP);
  const float zero[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  glClearNamedFramebufferfv(geometry_framebuffer.id(), GL_COLOR, 0, zero);
  glClearNamedFramebufferfv(geometry_framebuffer.id(), GL_COLOR, 1, zero);
  const GLint no_triangle[4] = {-1, -1, -1, -1};
  glClearNamedFramebufferiv(geometry_framebuffer.id(), GL_COLOR, 2, no_triangle);
  glUseProgram(geometry_program.id());
  DrawMesh();
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glUseProgram(0);
  glBindVertexArray(0);
  return gl::CheckGlError("Resampler::SetFrame: geometry atlas");
}

absl::Status Resampler::Impl::EnsureDepthMap(CameraState& camera) {
  if (camera.depth_frame == frame) return absl::OkStatus();
  // Near and far planes around the pose's bounding sphere (the depth buffer
  // only selects the nearest surface; the stored value is the exact 1 / z).
  const render::ClipRange clip = render::ClipRangeOf(camera.model, bounds.center, bounds.radius);
  const double near_plane = clip.near_plane, far_plane = clip.far_plane;
  const DepthMapLayout& layout = camera.layout;
  const glm::dmat4 cam_from_world = render::CamFromWorldMatrix(camera.model);
  const glm::mat4 clip_from_world(
      render::ClipFromCamera(camera.model, layout.cx, layout.cy, layout.width, layout.height, near_plane, far_plane) *
      cam_from_world);
  const glm::mat4 cam_from_world_f(cam_from_world);
  glProgramUniformMatrix4fv(depth_program.id(), kDepthClipFromWorld, 1, GL_FALSE, glm::value_ptr(clip_from_world));
  glProgramUniformMatrix4fv(depth_program.id(), kDepthCamFromWorld, 1, GL_FALSE, glm::value_ptr(cam_from_world_f));

  glBindFramebuffer(GL_FRAMEBUFFER, camera.depth_framebuffer.id());
  glViewport(0, 0, layout.width, layout.height);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glDisable(GL_CULL_FACE);  // both sides of every triangle occlude
  glDisable(GL_BLEND);
  glDisable(GL_COLOR_LOGIC_OP);
  const float no_surface[4] = {0.0f, 0.0f, 0.0f, 0.0f};  // inverse depth of "infinitely far"
  const float clear_depth = 1.0f;
  glClearNamedFramebufferfv(camera.depth_framebuffer.id(), GL_COLOR, 0, no_surface);
  glClearNamedFramebufferfv(camera.depth_framebuffer.id(), GL_COLOR, 1, no_surface);
  glClearNamedFramebufferfv(camera.depth_framebuffer.id(), GL_COLOR, 2, no_surface);
  const GLint no_triangle[4] = {-1, -1, -1, -1};
  glClearNamedFramebufferiv(camera.depth_framebuffer.id(), GL_COLOR, 3, no_triangle);
  glProgramUniform1i(depth_program.id(), kDepthAtlasSize, size);
  glClearNamedFramebufferfv(camera.depth_framebuffer.id(), GL_DEPTH, 0, &clear_depth);
  glUseProgram(depth_program.id());
  DrawMesh();
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glUseProgram(0);
  glBindVertexArray(0);
  MVBRDF_RETURN_IF_ERROR(gl::CheckGlError("Resampler: camera depth map"));
  camera.depth_frame = frame;
  return absl::OkStatus();
}

absl::Status Resampler::Impl::UploadFrame(CameraState& camera, const cv::Mat& frame_rgb) {
  if (!camera.frame_texture) {
    camera.frame_texture = CreateTexture2D(GL_RGB32F, camera.model.width, camera.model.height, GL_LINEAR);
  }
  // Rows as they are: image row 0 (top) is texture row 0 (t = 0), the same
  // orientation the shader's pixel coordinates use.
  cv::Mat data = frame_rgb;
  if (data.step[0] % data.elemSize() != 0) data = frame_rgb.clone();
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, static_cast<GLint>(data.step[0] / data.elemSize()));
  glTextureSubImage2D(camera.frame_texture.id(), 0, 0, 0, data.cols, data.rows, GL_RGB, GL_FLOAT, data.data);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  return gl::CheckGlError("Resampler::ResampleCamera: uploading the frame");
}

void Resampler::Impl::ReadAtlas(GLuint framebuffer, GLenum attachment, GLenum format, GLenum type, cv::Mat* out) const {
  // Window row r is atlas row r (shaders/resample_geometry.vert), so the
  // read-back is already top row first. Read in the target's own format
  // (PERF.md: converting formats in glReadPixels is several times slower).
  glNamedFramebufferReadBuffer(framebuffer, attachment);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, framebuffer);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glPixelStorei(GL_PACK_ROW_LENGTH, 0);
  glReadPixels(0, 0, size, size, format, type, out->data);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
}

absl::StatusOr<cv::Mat> Resampler::ResampleCamera(int camera, const cv::Mat& frame) {
  Impl& r = *impl_;
  MVBRDF_RETURN_IF_ERROR(r.CheckReady("Resampler::ResampleCamera"));
  if (camera < 0 || camera >= static_cast<int>(r.cameras.size())) {
    return absl::InvalidArgumentError(
        absl::StrCat("camera: index ", camera, " out of range, ", r.cameras.size(), " cameras"));
  }
  CameraState& state = r.cameras[camera];
  if (frame.type() != CV_32FC3 || frame.cols != state.model.width || frame.rows != state.model.height) {
    return absl::InvalidArgumentError(absl::StrCat(
        "frame of cameras[", camera, "] (\"", state.model.name, "\"): expected CV_32FC3 ", state.model.width, "x",
        state.model.height, ", got type ", frame.type(), " ", frame.cols, "x", frame.rows));
  }
  MVBRDF_RETURN_IF_ERROR(r.EnsureDepthMap(state));
  MVBRDF_RETURN_IF_ERROR(r.UploadFrame(state, frame));

  const scene::CameraModel& m = state.model;
  const GLuint program = r.camera_program.id();
  const glm::mat4 cam_from_world(render::CamFromWorldMatrix(m));
  const glm::vec4 view_origin(m.ViewOrigin());
  const glm::dvec2 scale = m.PixelScale();
  glProgramUniformMatrix4fv(program, kCamFromWorld, 1, GL_FALSE, glm::value_ptr(cam_from_world));
  glProgramUniform4fv(program, kCameraCenter, 1, glm::value_ptr(view_origin));
  glProgramUniform4f(program, kIntrinsics, static_cast<float>(scale.x), static_cast<float>(scale.y),
                     static_cast<float>(m.cx), static_cast<float>(m.cy));
  glProgramUniform1i(program, kOrthographic, m.orthographic() ? 1 : 0);
  glProgramUniform2f(program, kDepthPrincipal, static_cast<float>(state.layout.cx),
                     static_cast<float>(state.layout.cy));
  const std::vector<double>& k = m.distortion;
  glProgramUniform4f(program, kDistortionA, static_cast<float>(k[0]), static_cast<float>(k[1]),
                     static_cast<float>(k[2]), static_cast<float>(k[3]));
  glProgramUniform4f(program, kDistortionB, static_cast<float>(k[4]), static_cast<float>(k[5]),
                     static_cast<float>(k[6]), static_cast<float>(k[7]));
  glProgramUniform1f(program, kMinCosView,
                     static_cast<float>(std::sin(r.options.grazing_margin_deg * 3.14159265358979323846 / 180.0)));
  glProgramUniform1f(program, kDepthScale, static_cast<float>(1.0 + r.options.relative_depth_tolerance));
  glProgramUniform1f(program, kDepthAbsolute, static_cast<float>(r.options.absolute_depth_tolerance));
  glProgramUniform1f(program, kOccluderTolerance,
                     r.options.exact_occluder_test ? static_cast<float>(kOccluderRelativeTolerance) : -1.0f);
  glProgramUniform1f(
      program, kOccluderMarginOrthographic,
      static_cast<float>(kOccluderRelativeTolerance * (glm::length(glm::dvec3(r.bounds.center)) + r.bounds.radius)));

  glBindTextureUnit(kPositionMapUnit, r.position_map.id());
  glBindTextureUnit(kNormalMapUnit, r.normal_map.id());
  glBindTextureUnit(kDepthMapUnit, state.depth_map.id());
  glBindTextureUnit(kFrameUnit, state.frame_texture.id());
  glBindTextureUnit(kTexelTriangleUnit, r.triangle_map.id());
  glBindTextureUnit(kPixelTriangleUnit, state.surface_triangle.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kCornersBinding, r.corner_buffer.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kCornerIdsBinding, r.corner_id_buffer.id());
  glBindFramebuffer(GL_FRAMEBUFFER, r.resample_framebuffer.id());
  glViewport(0, 0, r.size, r.size);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glDisable(GL_BLEND);
  glDisable(GL_COLOR_LOGIC_OP);
  glUseProgram(program);
  r.DrawFullScreen();  // writes every texel: no clear needed

  cv::Mat out(r.size, r.size, CV_32FC4);
  r.ReadAtlas(r.resample_framebuffer.id(), GL_COLOR_ATTACHMENT0, GL_RGBA, GL_FLOAT, &out);
  // The shader writes a = the invalid pixel's mark where a footprint touched
  // one (shaders/resample_camera.frag): counted, then invalid like the rest.
  for (int y = 0; y < out.rows; ++y) {
    cv::Vec4f* row = out.ptr<cv::Vec4f>(y);
    for (int x = 0; x < out.cols; ++x) {
      if (row[x][3] > 0.5f) ++state.refused.kept;
      if (!(row[x][3] < 0.0f)) continue;
      if (row[x][3] == scene::kSaturatedPixel) ++state.refused.saturated;
      else if (row[x][3] == kEdgePixel)
        ++state.refused.edge;
      else if (row[x][3] == kGradientPixel)
        ++state.refused.gradient;
      else ++state.refused.masked;
      row[x] = cv::Vec4f(0.0f, 0.0f, 0.0f, 0.0f);
    }
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glUseProgram(0);
  glBindVertexArray(0);
  for (GLuint unit = 0; unit < 6; ++unit) glBindTextureUnit(unit, 0);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kCornersBinding, 0);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kCornerIdsBinding, 0);
  MVBRDF_RETURN_IF_ERROR(gl::CheckGlError("Resampler::ResampleCamera"));
  return out;
}

absl::Status Resampler::MarkUnreliable(int camera, cv::Mat* frame) {
  Impl& r = *impl_;
  if (r.options.edge_margin_pixels <= 0.0 && r.options.gradient_rejection <= 0.0) return absl::OkStatus();
  MVBRDF_RETURN_IF_ERROR(r.CheckReady("Resampler::MarkUnreliable"));
  if (camera < 0 || camera >= static_cast<int>(r.cameras.size())) {
    return absl::InvalidArgumentError(
        absl::StrCat("camera: index ", camera, " out of range, ", r.cameras.size(), " cameras"));
  }
  CameraState& state = r.cameras[static_cast<size_t>(camera)];
  const scene::CameraModel& m = state.model;
  if (frame->type() != CV_32FC3 || frame->cols != m.width || frame->rows != m.height) {
    return absl::InvalidArgumentError(absl::StrCat("frame of cameras[", camera, "]: expected CV_32FC3 ", m.width, "x",
                                                   m.height, ", got type ", frame->type()));
  }
  const auto mark = [&](int y, int x, float value) {
    cv::Vec3f& p = frame->at<cv::Vec3f>(y, x);
    if (p[0] < 0.0f) return;  // already marked (masked, saturated, edge)
    p = cv::Vec3f(value, value, value);
  };
  if (r.options.edge_margin_pixels > 0.0) {
    MVBRDF_RETURN_IF_ERROR(r.EnsureDepthMap(state));
    const DepthMapLayout& layout = state.layout;
    cv::Mat inverse_depth(layout.height, layout.width, CV_32FC1);
    glNamedFramebufferReadBuffer(state.depth_framebuffer.id(), GL_COLOR_ATTACHMENT0);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, state.depth_framebuffer.id());
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glPixelStorei(GL_PACK_ROW_LENGTH, 0);
    glReadPixels(0, 0, layout.width, layout.height, GL_RED, GL_FLOAT, inverse_depth.data);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
    MVBRDF_RETURN_IF_ERROR(gl::CheckGlError("Resampler::MarkUnreliable"));
    // Edge sources (0): pixels without surface, and depth discontinuities:
    // where inverse depth, affine in the image over a plane (pinhole), is
    // not locally affine: |d(x - 1) - 2 d(x) + d(x + 1)| > t d(x) along a row
    // or a column (the three pixels and their neighbours are sources).
    cv::Mat not_edge(layout.height, layout.width, CV_8UC1, cv::Scalar(255));
    const auto d_at = [&](int x, int y) { return inverse_depth.at<float>(y, x); };
    for (int y = 0; y < layout.height; ++y) {
      for (int x = 0; x < layout.width; ++x) {
        const float d = d_at(x, y);
        if (!(d > 0.0f)) {
          not_edge.at<uint8_t>(y, x) = 0;
          continue;
        }
        for (const auto& [dx, dy] : {std::pair{1, 0}, std::pair{0, 1}}) {
          const int x0 = x - dx, y0 = y - dy, x1 = x + dx, y1 = y + dy;
          if (x0 < 0 || y0 < 0 || x1 >= layout.width || y1 >= layout.height) continue;
          const float a = d_at(x0, y0), b = d_at(x1, y1);
          if (!(a > 0.0f) || !(b > 0.0f)) continue;  // a silhouette: the background pixel is a source
          if (std::fabs(a - 2.0 * d + b) > kDepthDiscontinuity * d) {
            not_edge.at<uint8_t>(y0, x0) = 0;
            not_edge.at<uint8_t>(y, x) = 0;
            not_edge.at<uint8_t>(y1, x1) = 0;
          }
        }
      }
    }
    cv::Mat distance;
    cv::distanceTransform(not_edge, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    const float margin = static_cast<float>(r.options.edge_margin_pixels);
    for (int y = 0; y < m.height; ++y) {
      for (int x = 0; x < m.width; ++x) {
        // The depth-map pixel of this image pixel (as samples::ForEachPixelSample).
        double px = x - m.cx + layout.cx, py = y - m.cy + layout.cy;
        if (m.has_distortion()) {
          const glm::dvec2 u = m.Undistort({(x - m.cx) / m.fx, (y - m.cy) / m.fy});
          px = m.fx * u.x + layout.cx;
          py = m.fy * u.y + layout.cy;
        }
        const int mx = static_cast<int>(std::lround(px)), my = static_cast<int>(std::lround(py));
        if (mx < 0 || my < 0 || mx >= layout.width || my >= layout.height) continue;
        if (!(inverse_depth.at<float>(my, mx) > 0.0f)) continue;  // background: not a Sample anyway
        if (distance.at<float>(my, mx) <= margin) mark(y, x, kEdgePixel);
      }
    }
  }
  if (r.options.gradient_rejection > 0.0) {
    cv::Mat luminance(m.height, m.width, CV_32FC1);
    for (int y = 0; y < m.height; ++y) {
      for (int x = 0; x < m.width; ++x) {
        const cv::Vec3f& p = frame->at<cv::Vec3f>(y, x);
        luminance.at<float>(y, x) = p[0] < 0.0f ? -1.0f : (p[0] + p[1] + p[2]) / 3.0f;
      }
    }
    const double limit = r.options.gradient_rejection;
    for (int y = 1; y + 1 < m.height; ++y) {
      for (int x = 1; x + 1 < m.width; ++x) {
        double sum = 0.0;
        bool valid = true;
        for (int dy = -1; dy <= 1 && valid; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const float v = luminance.at<float>(y + dy, x + dx);
            if (v < 0.0f) valid = false;
            sum += v;
          }
        }
        if (!valid) continue;  // next to a marked pixel: the marks decide
        const double mean = sum / 9.0;
        const double gx = 0.5 * (luminance.at<float>(y, x + 1) - luminance.at<float>(y, x - 1));
        const double gy = 0.5 * (luminance.at<float>(y + 1, x) - luminance.at<float>(y - 1, x));
        const double g = std::sqrt(gx * gx + gy * gy);
        if (g > limit * mean) mark(y, x, kGradientPixel);
      }
    }
  }
  return absl::OkStatus();
}

Resampler::RefusedObservations Resampler::Refused(int camera) const {
  if (camera < 0 || camera >= static_cast<int>(impl_->cameras.size())) return {};
  return impl_->cameras[static_cast<size_t>(camera)].refused;
}

absl::StatusOr<CameraSurface> Resampler::Surface(int camera) {
  Impl& r = *impl_;
  MVBRDF_RETURN_IF_ERROR(r.CheckReady("Resampler::Surface"));
  if (camera < 0 || camera >= static_cast<int>(r.cameras.size())) {
    return absl::OutOfRangeError(absl::StrCat("Resampler::Surface: no camera ", camera));
  }
  CameraState& state = r.cameras[static_cast<size_t>(camera)];
  MVBRDF_RETURN_IF_ERROR(r.EnsureDepthMap(state));
  CameraSurface surface;
  surface.cx = state.layout.cx;
  surface.cy = state.layout.cy;
  surface.position_texel.create(state.layout.height, state.layout.width, CV_32FC4);
  surface.normal.create(state.layout.height, state.layout.width, CV_32FC4);
  // Window row r is image row r (the depth pass's projection), so no flip.
  for (auto [attachment, out] : {std::pair<GLenum, cv::Mat*>{GL_COLOR_ATTACHMENT1, &surface.position_texel},
                                 std::pair<GLenum, cv::Mat*>{GL_COLOR_ATTACHMENT2, &surface.normal}}) {
    glNamedFramebufferReadBuffer(state.depth_framebuffer.id(), attachment);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, state.depth_framebuffer.id());
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glPixelStorei(GL_PACK_ROW_LENGTH, 0);
    glReadPixels(0, 0, state.layout.width, state.layout.height, GL_RGBA, GL_FLOAT, out->data);
  }
  if (HasTriangleMaps(state.model, r.options)) {
    surface.triangle.create(state.layout.height, state.layout.width, CV_32SC1);
    glNamedFramebufferReadBuffer(state.depth_framebuffer.id(), GL_COLOR_ATTACHMENT3);
    glReadPixels(0, 0, state.layout.width, state.layout.height, GL_RED_INTEGER, GL_INT, surface.triangle.data);
    surface.triangles = r.surface_triangles;
  }
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  MVBRDF_RETURN_IF_ERROR(gl::CheckGlError("Resampler::Surface"));
  return surface;
}

absl::StatusOr<GeometryAtlas> Resampler::Geometry() {
  Impl& r = *impl_;
  MVBRDF_RETURN_IF_ERROR(r.CheckReady("Resampler::Geometry"));
  GeometryAtlas geometry;
  geometry.position.create(r.size, r.size, CV_32FC4);
  geometry.normal.create(r.size, r.size, CV_32FC4);
  r.ReadAtlas(r.geometry_framebuffer.id(), GL_COLOR_ATTACHMENT0, GL_RGBA, GL_FLOAT, &geometry.position);
  r.ReadAtlas(r.geometry_framebuffer.id(), GL_COLOR_ATTACHMENT1, GL_RGBA, GL_FLOAT, &geometry.normal);
  MVBRDF_RETURN_IF_ERROR(gl::CheckGlError("Resampler::Geometry"));
  return geometry;
}

absl::StatusOr<cv::Mat> Resampler::ShadowAtlas(const std::vector<bool>& lights_needed) {
  Impl& r = *impl_;
  MVBRDF_RETURN_IF_ERROR(r.CheckReady("Resampler::ShadowAtlas"));
  const size_t num_lights = r.lights.size();
  if (!lights_needed.empty() && lights_needed.size() != num_lights) {
    return absl::InvalidArgumentError(absl::StrCat("lights_needed: expected empty or ", num_lights,
                                                   " entries (one per light), got ", lights_needed.size()));
  }
  const std::vector<bool> needed = lights_needed.empty() ? std::vector<bool>(num_lights, true) : lights_needed;
  if (r.shadow_frame == r.frame && !r.shadow_atlas.empty() && r.shadow_lights == needed) {
    return r.shadow_atlas.clone();
  }
  const int channels = std::max(1, static_cast<int>((num_lights + kLightsPerPass - 1) / kLightsPerPass));
  cv::Mat visible(r.size, r.size, CV_16UC(channels), cv::Scalar::all(0));
  cv::Mat pass_bits(r.size, r.size, CV_16UC1);
  // One pass per channel that has a needed light: shadow maps of just those
  // lights, then the full-screen test writing their bits.
  for (int c = 0; c < channels; ++c) {
    std::vector<scene::Light> pass_lights;
    std::vector<int> pass_bit;
    for (size_t k = static_cast<size_t>(c) * kLightsPerPass;
         k < std::min(num_lights, static_cast<size_t>(c + 1) * kLightsPerPass); ++k) {
      if (!needed[k]) continue;
      pass_lights.push_back(r.lights[k]);
      pass_bit.push_back(static_cast<int>(k % kLightsPerPass));
    }
    if (pass_lights.empty()) continue;
    MVBRDF_RETURN_IF_ERROR(r.shadow_maps->Render(pass_lights, r.bounds, [&r] { r.DrawMesh(); }));
    GpuShadowLightBlock block{};
    block.count = glm::ivec4(static_cast<int>(pass_lights.size()), 0, 0, 0);
    for (size_t i = 0; i < pass_lights.size(); ++i) {
      const render::LightShadow& shadow = r.shadow_maps->light_shadows()[i];
      block.lights[i] = {shadow.position, shadow.shadow, shadow.shadow_from_world};
      block.lights[i].shadow.w = static_cast<float>(pass_bit[i]);  // the bit it sets
    }
    glNamedBufferSubData(r.light_buffer.id(), 0, sizeof(GpuShadowLightBlock), &block);

    glBindTextureUnit(kPositionMapUnit, r.position_map.id());
    glBindTextureUnit(kNormalMapUnit, r.normal_map.id());
    glBindTextureUnit(kPointShadowUnit, r.shadow_maps->point_maps().id());
    glBindTextureUnit(kDirectionalShadowUnit, r.shadow_maps->directional_maps().id());
    glBindBufferBase(GL_UNIFORM_BUFFER, kShadowLightBlockBinding, r.light_buffer.id());
    glBindFramebuffer(GL_FRAMEBUFFER, r.shadow_atlas_framebuffer.id());
    glViewport(0, 0, r.size, r.size);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glDisable(GL_BLEND);
    glDisable(GL_COLOR_LOGIC_OP);
    glUseProgram(r.shadow_atlas_program.id());
    r.DrawFullScreen();  // writes every texel
    cv::Mat* target = channels == 1 ? &visible : &pass_bits;
    r.ReadAtlas(r.shadow_atlas_framebuffer.id(), GL_COLOR_ATTACHMENT0, GL_RED_INTEGER, GL_UNSIGNED_SHORT, target);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glUseProgram(0);
    glBindVertexArray(0);
    glBindBufferBase(GL_UNIFORM_BUFFER, kShadowLightBlockBinding, 0);
    for (GLuint unit = 0; unit < 4; ++unit) glBindTextureUnit(unit, 0);
    MVBRDF_RETURN_IF_ERROR(gl::CheckGlError("Resampler::ShadowAtlas"));
    if (channels > 1) {
      const int from_to[2] = {0, c};
      cv::mixChannels(&pass_bits, 1, &visible, 1, from_to, 1);
    }
  }
  r.shadow_atlas = visible;
  r.shadow_lights = needed;
  r.shadow_frame = r.frame;
  return visible.clone();
}

}  // namespace mvbrdf::resample
