#include "core/render/phong_renderer.h"

#include "core/render/camera_projection.h"
#include "core/scene/tangent_frames.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/gtc/type_ptr.hpp>
#include <limits>
#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/brdf/ggx.h"
#include "core/gl/gl_api.h"
#include "core/gl/gl_objects.h"
#include "core/gl/shader_program.h"
#include "core/render/shadow_maps.h"

namespace mvbrdf::render {
namespace {

// Lights per shading pass (shaders/phong.frag kMaxLights); more lights are
// drawn in several passes whose radiance is summed.
constexpr int kLightsPerPass = 16;
constexpr int kMaxMaterials = 64;

// std140 mirror of GpuLight in shaders/phong.frag.
struct GpuLight {
  glm::vec4 position;
  glm::vec4 intensity;
  glm::vec4 shadow;
  glm::mat4 shadow_from_world;
};
static_assert(sizeof(GpuLight) == 112, "std140 layout of GpuLight");

struct GpuLightBlock {
  glm::ivec4 count;
  GpuLight lights[kLightsPerPass];
};

// std430 mirror of GpuMaterial in shaders/phong.frag.
struct GpuMaterial {
  glm::vec4 base_amplitude;
  glm::vec4 offset_frequency;
  glm::vec4 ks_kd_from_texture;
  glm::vec4 ke;
  glm::vec4 p3;  // rgb: the model's third parameter (GGX's f90_ratio)
};
static_assert(sizeof(GpuMaterial) == 80, "std430 layout of GpuMaterial");

// Texture units and buffer bindings, as declared in shaders/phong.frag.
enum TextureUnit : GLuint {
  kKdTextureUnit = 0,
  kAtlasKdUnit = 1,
  kAtlasKsUnit = 2,
  kAtlasKeUnit = 3,
  kPointShadowUnit = 4,
  kDirectionalShadowUnit = 5,
  kAtlasModelUnit = 6,
  kAtlasP3Unit = 7,
  kAtlasGgxSupportUnit = 8,
  kAtlasNormalUnit = 9,
};
constexpr GLuint kLightBlockBinding = 0;
constexpr GLuint kMaterialBlockBinding = 1;
constexpr GLuint kTriangleMaterialBlockBinding = 2;
constexpr GLuint kNbrdfWeightsBinding = 3;  // NBRDF_WEIGHTS_BINDING in phong.frag

// Uniform locations (layout(location = ...) in the shaders).
constexpr GLint kClipFromWorldLocation = 0;
constexpr GLint kCameraCenterLocation = 1;
constexpr GLint kAtlasModeLocation = 2;
constexpr GLint kFalloffLocation = 3;
constexpr GLint kUvSpaceLocation = 4;
constexpr GLint kBrdfModelLocation = 5;
// Issue #18: 0 the mesh's normals, 1 the procedural detail (NormalDetail),
// 2 the tangent-space normal atlas.
constexpr GLint kNormalModeLocation = 6;
constexpr GLint kNormalDetailLocation = 7;  // vec4: amplitude, wavelength
constexpr GLint kNormalDetailD1Location = 8;
constexpr GLint kNormalDetailD2Location = 9;

// Uploads an image with row 0 = v = 1 into a 2D RGB32F texture with row 0 at
// t = 0 (GL's convention), i.e. flipped.
absl::StatusOr<gl::Texture> UploadUvImage(const cv::Mat& image, absl::string_view what) {
  if (image.empty() || image.type() != CV_32FC3) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": expected a non-empty CV_32FC3 image, got type ",
                                                   image.type(), " of size ", image.cols, "x", image.rows));
  }
  cv::Mat flipped;
  cv::flip(image, flipped, 0);  // continuous output
  gl::Texture texture = gl::CreateTexture(GL_TEXTURE_2D);
  glTextureStorage2D(texture.id(), 1, GL_RGB32F, image.cols, image.rows);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  glTextureSubImage2D(texture.id(), 0, 0, 0, image.cols, image.rows, GL_RGB, GL_FLOAT, flipped.data);
  glTextureParameteri(texture.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(texture.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(texture.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(texture.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  MVBRDF_RETURN_IF_ERROR(gl::CheckGlError(absl::StrCat("uploading ", what)));
  return texture;
}

// A framebuffer with one colour and one depth renderbuffer, reallocated when
// the requested size changes. Render, RenderAtlas and RenderTriangleIds each
// keep their own, so that alternating between them reallocates nothing.
struct RenderTarget {
  explicit RenderTarget(GLenum format) : color_format(format) {}

  GLenum color_format;  // sized internal format of the colour renderbuffer
  int width = 0, height = 0;
  gl::Framebuffer framebuffer;
  gl::Renderbuffer color;
  gl::Renderbuffer depth;  // DEPTH_COMPONENT32F

  absl::Status Ensure(int new_width, int new_height, absl::string_view what) {
    if (framebuffer && new_width == width && new_height == height) return absl::OkStatus();
    framebuffer = gl::CreateFramebuffer();
    color = gl::CreateRenderbuffer();
    glNamedRenderbufferStorage(color.id(), color_format, new_width, new_height);
    depth = gl::CreateRenderbuffer();
    glNamedRenderbufferStorage(depth.id(), GL_DEPTH_COMPONENT32F, new_width, new_height);
    glNamedFramebufferRenderbuffer(framebuffer.id(), GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color.id());
    glNamedFramebufferRenderbuffer(framebuffer.id(), GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth.id());
    glNamedFramebufferDrawBuffer(framebuffer.id(), GL_COLOR_ATTACHMENT0);
    glNamedFramebufferReadBuffer(framebuffer.id(), GL_COLOR_ATTACHMENT0);
    MVBRDF_RETURN_IF_ERROR(gl::CheckGlError(absl::StrCat("allocating the ", what)));
    MVBRDF_RETURN_IF_ERROR(gl::CheckFramebufferComplete(framebuffer, what));
    width = new_width;
    height = new_height;
    return absl::OkStatus();
  }
};

// The largest side a render target may have: the renderbuffer and viewport limits.
int MaxTargetSide() {
  GLint renderbuffer = 0;
  GLint viewport[2] = {0, 0};
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &renderbuffer);
  glGetIntegerv(GL_MAX_VIEWPORT_DIMS, viewport);
  return std::min({renderbuffer, viewport[0], viewport[1]});
}

}  // namespace

struct PhongRenderer::Impl {
  gl::EglContext* context = nullptr;
  RendererOptions options;
  size_t num_vertices = 0;
  GLsizei num_indices = 0;
  uint32_t max_material_id = 0;
  bool has_uvs = false;

  gl::VertexArray vertex_array;
  gl::Buffer position_buffer;  // per frame
  gl::Buffer normal_buffer;    // per frame
  gl::Buffer rest_position_buffer;
  gl::Buffer uv_buffer;
  gl::Buffer tangent_buffer;  // per frame, with a normal detail or atlas (scene::VertexTangents)
  std::vector<glm::uvec3> triangles;  // for the tangents
  std::vector<glm::vec2> uvs;
  gl::Buffer index_buffer;
  gl::Buffer triangle_material_buffer;
  gl::Buffer material_buffer;
  gl::Buffer light_buffer;
  gl::Buffer nbrdf_buffer;  // the measured BRDFs' weights (one zero block when none)
  size_t num_measured = 0;

  gl::Program phong_program;
  gl::Program triangle_id_program;

  // 1x1 stand-ins so that every sampler of phong.frag always has a texture.
  gl::Texture placeholder_texture;
  gl::Texture kd_texture;
  gl::Texture atlas_kd, atlas_ks, atlas_ke;
  gl::Texture atlas_model;  // per-texel model (empty: options.brdf_model everywhere)
  gl::Texture atlas_p3;     // the third parameter (1x1 of GGX's dielectric ratio when none was given)
  gl::Texture atlas_ggx_support;  // GGX's grazing support per texel (empty: 0, the plain lobe)
  gl::Texture atlas_normal;       // tangent-space normals per texel (empty: the mesh's normals)
  NormalDetail normal_detail;     // the procedural materials' detail (amplitude 0: none)
  // Whether the pose's tangents are needed (a detail or a normal atlas).
  bool NeedsTangents() const { return normal_detail.amplitude != 0.0f || static_cast<bool>(atlas_normal); }

  enum class Mode { kNone, kProcedural, kAtlas };
  Mode mode = Mode::kNone;
  bool needs_kd_texture = false;

  std::vector<scene::Light> lights;
  std::unique_ptr<ShadowMaps> shadow_maps;

  RenderTarget camera_target{GL_RGBA32F};    // Render
  RenderTarget atlas_target{GL_RGBA32F};     // RenderAtlas
  RenderTarget triangle_id_target{GL_R32I};  // RenderTriangleIds
  std::vector<float> readback;

  // Shadow maps depend on the positions and the lights only, not on the
  // camera: rendering one pose from several cameras renders them once.
  bool shadows_valid = false;
  int shadow_pass = 0;                      // the light pass the shadow maps and light block hold
  std::vector<glm::vec3> shadow_positions;  // the positions the shadow maps were rendered for
  BoundingSphere bounds;                    // of the pose of the last PreparePose

  int NumLightPasses() const {
    return std::max(1, static_cast<int>((lights.size() + kLightsPerPass - 1) / kLightsPerPass));
  }

  // FAILED_PRECONDITION unless the context is current here; INVALID_ARGUMENT
  // unless the pose has one position and normal per render vertex.
  absl::Status CheckContextAndPose(absl::string_view caller, const Pose& pose) const;
  // FAILED_PRECONDITION unless the materials are complete.
  absl::Status CheckMaterials(absl::string_view caller) const;
  // Uploads the pose's positions and normals and its bounds.
  void PreparePose(const Pose& pose);
  // Unless still valid, renders the shadow maps of light pass `pass` (lights
  // [16 pass, 16 pass + 16)) for the pose's positions and uploads its lights.
  absl::Status PrepareLightPass(const Pose& pose, int pass);
  // The main pass of phong.vert/phong.frag into `target` (cleared to 0),
  // once per light pass with the radiance summed: placed by
  // `clip_from_world` (depth-tested) or, with `uv_space`, at the UVs (no
  // depth test), shaded as seen from `camera_center`. Leaves the RGBA floats
  // of the target, bottom window row first, in `readback`.
  absl::Status DrawShaded(const Pose& pose, const glm::mat4& clip_from_world, const glm::vec4& camera_center,
                          bool uv_space, RenderTarget& target);
  absl::Status DrawShadedPass(const glm::mat4& clip_from_world, const glm::vec4& camera_center, bool uv_space,
                              RenderTarget& target, std::vector<float>* out);
  std::vector<float> pass_readback;
  void Draw() const {
    glBindVertexArray(vertex_array.id());
    glDrawElements(GL_TRIANGLES, num_indices, GL_UNSIGNED_INT, nullptr);
  }
};

absl::StatusOr<std::unique_ptr<PhongRenderer>> PhongRenderer::Create(gl::EglContext& context, const RenderMesh& mesh,
                                                                     const RendererOptions& options) {
  if (!context.IsCurrent()) {
    return absl::FailedPreconditionError("PhongRenderer::Create: the EGL context is not current on this thread");
  }
  if (options.shadow_map_size < 1 || options.shadow_map_size > 8192) {
    return absl::InvalidArgumentError(
        absl::StrCat("options.shadow_map_size: must be in [1, 8192], got ", options.shadow_map_size));
  }
  const size_t n = mesh.rest_positions.size();
  if (n == 0) return absl::InvalidArgumentError("mesh.rest_positions: empty; it defines the render vertices");
  if (n > static_cast<size_t>(std::numeric_limits<GLint>::max())) {
    return absl::InvalidArgumentError(absl::StrCat("mesh.rest_positions: too many vertices (", n, ")"));
  }
  if (!mesh.uvs.empty() && mesh.uvs.size() != n) {
    return absl::InvalidArgumentError(
        absl::StrCat("mesh.uvs: expected empty or ", n, " entries (one per render vertex), got ", mesh.uvs.size()));
  }
  if (!mesh.triangle_material.empty() && mesh.triangle_material.size() != mesh.triangles.size()) {
    return absl::InvalidArgumentError(absl::StrCat("mesh.triangle_material: expected empty or ", mesh.triangles.size(),
                                                   " entries (one per triangle), got ", mesh.triangle_material.size()));
  }
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const glm::uvec3& tri = mesh.triangles[t];
    if (tri.x >= n || tri.y >= n || tri.z >= n) {
      return absl::InvalidArgumentError(absl::StrCat("mesh.triangles[", t, "]: vertex index out of range (", tri.x,
                                                     ", ", tri.y, ", ", tri.z, "), ", n, " vertices"));
    }
  }

  auto impl = std::make_unique<Impl>();
  impl->context = &context;
  impl->options = options;
  impl->num_vertices = n;
  impl->num_indices = static_cast<GLsizei>(mesh.triangles.size() * 3);
  impl->has_uvs = !mesh.uvs.empty();
  for (uint32_t id : mesh.triangle_material) impl->max_material_id = std::max(impl->max_material_id, id);

  MVBRDF_ASSIGN_OR_RETURN(impl->phong_program, gl::BuildProgram({{GL_VERTEX_SHADER, "phong.vert", {}},
                                                                 {GL_FRAGMENT_SHADER, "phong.frag", {}}}));
  MVBRDF_ASSIGN_OR_RETURN(impl->triangle_id_program, gl::BuildProgram({{GL_VERTEX_SHADER, "shadow.vert", {}},
                                                                       {GL_FRAGMENT_SHADER, "triangle_id.frag", {}}}));

  const GLsizeiptr vec3_bytes = static_cast<GLsizeiptr>(n * sizeof(glm::vec3));
  impl->position_buffer = gl::CreateBuffer();
  glNamedBufferStorage(impl->position_buffer.id(), vec3_bytes, nullptr, GL_DYNAMIC_STORAGE_BIT);
  impl->normal_buffer = gl::CreateBuffer();
  glNamedBufferStorage(impl->normal_buffer.id(), vec3_bytes, nullptr, GL_DYNAMIC_STORAGE_BIT);
  impl->rest_position_buffer = gl::CreateBuffer();
  glNamedBufferStorage(impl->rest_position_buffer.id(), vec3_bytes, mesh.rest_positions.data(), 0);
  impl->uv_buffer = gl::CreateBuffer();
  if (impl->has_uvs) {
    glNamedBufferStorage(impl->uv_buffer.id(), static_cast<GLsizeiptr>(n * sizeof(glm::vec2)), mesh.uvs.data(), 0);
  }
  impl->tangent_buffer = gl::CreateBuffer();
  glNamedBufferStorage(impl->tangent_buffer.id(), static_cast<GLsizeiptr>(n * sizeof(glm::vec4)), nullptr,
                       GL_DYNAMIC_STORAGE_BIT);
  impl->triangles = mesh.triangles;
  impl->uvs = mesh.uvs;
  impl->index_buffer = gl::CreateBuffer();
  // Zero-sized storage is legal; keep one element so the buffer always exists.
  std::vector<glm::uvec3> triangles = mesh.triangles;
  if (triangles.empty()) triangles.emplace_back(0u);
  glNamedBufferStorage(impl->index_buffer.id(), static_cast<GLsizeiptr>(triangles.size() * sizeof(glm::uvec3)),
                       triangles.data(), 0);
  std::vector<uint32_t> triangle_material = mesh.triangle_material;
  if (triangle_material.empty()) triangle_material.assign(std::max<size_t>(mesh.triangles.size(), 1), 0u);
  impl->triangle_material_buffer = gl::CreateBuffer();
  glNamedBufferStorage(impl->triangle_material_buffer.id(),
                       static_cast<GLsizeiptr>(triangle_material.size() * sizeof(uint32_t)), triangle_material.data(),
                       0);
  impl->material_buffer = gl::CreateBuffer();
  glNamedBufferStorage(impl->material_buffer.id(), kMaxMaterials * sizeof(GpuMaterial), nullptr,
                       GL_DYNAMIC_STORAGE_BIT);
  impl->light_buffer = gl::CreateBuffer();
  glNamedBufferStorage(impl->light_buffer.id(), sizeof(GpuLightBlock), nullptr, GL_DYNAMIC_STORAGE_BIT);
  const std::vector<float> no_weights(brdf::NeuralBrdf::kNumWeights, 0.0f);
  impl->nbrdf_buffer = gl::CreateBuffer();
  glNamedBufferStorage(impl->nbrdf_buffer.id(), static_cast<GLsizeiptr>(no_weights.size() * sizeof(float)),
                       no_weights.data(), 0);

  impl->vertex_array = gl::CreateVertexArray();
  const GLuint vao = impl->vertex_array.id();
  const std::array<std::pair<GLuint, GLint>, 5> attributes = {{{impl->position_buffer.id(), 3},
                                                               {impl->normal_buffer.id(), 3},
                                                               {impl->rest_position_buffer.id(), 3},
                                                               {impl->uv_buffer.id(), 2},
                                                               {impl->tangent_buffer.id(), 4}}};
  for (GLuint i = 0; i < attributes.size(); ++i) {
    if (i == 3 && !impl->has_uvs) continue;  // disabled attribute reads as (0, 0)
    glVertexArrayVertexBuffer(vao, i, attributes[i].first, 0,
                              static_cast<GLsizei>(attributes[i].second * sizeof(float)));
    glVertexArrayAttribFormat(vao, i, attributes[i].second, GL_FLOAT, GL_FALSE, 0);
    glVertexArrayAttribBinding(vao, i, i);
    glEnableVertexArrayAttrib(vao, i);
  }
  glVertexArrayElementBuffer(vao, impl->index_buffer.id());

  const cv::Mat zero(1, 1, CV_32FC3, cv::Scalar(0, 0, 0));
  MVBRDF_ASSIGN_OR_RETURN(impl->placeholder_texture, UploadUvImage(zero, "placeholder texture"));
  // Allocated as the passes draw (at most kLightsPerPass lights each), not for every light at once.
  MVBRDF_ASSIGN_OR_RETURN(impl->shadow_maps, ShadowMaps::Create(options.shadow_map_size));
  MVBRDF_RETURN_IF_ERROR(gl::CheckGlError("PhongRenderer::Create"));
  return std::unique_ptr<PhongRenderer>(new PhongRenderer(std::move(impl)));
}

PhongRenderer::PhongRenderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
PhongRenderer::~PhongRenderer() = default;

absl::Status PhongRenderer::SetProceduralMaterials(const std::vector<ProceduralMaterial>& materials) {
  if (materials.empty() || materials.size() > kMaxMaterials) {
    return absl::InvalidArgumentError(
        absl::StrCat("materials: expected 1 to ", kMaxMaterials, " materials, got ", materials.size()));
  }
  if (impl_->max_material_id >= materials.size()) {
    return absl::InvalidArgumentError(absl::StrCat("materials: the mesh uses material ", impl_->max_material_id,
                                                   " but only ", materials.size(), " are given"));
  }
  std::vector<GpuMaterial> gpu(materials.size());
  bool needs_kd_texture = false;
  for (size_t i = 0; i < materials.size(); ++i) {
    const ProceduralMaterial& m = materials[i];
    if (m.kd_from_texture && !impl_->has_uvs) {
      return absl::InvalidArgumentError(
          absl::StrCat("materials[", i, "].kd_from_texture: the mesh has no uvs to look the texture up with"));
    }
    if (m.measured >= 0 && static_cast<size_t>(m.measured) >= impl_->num_measured) {
      return absl::InvalidArgumentError(absl::StrCat("materials[", i, "].measured: measured BRDF ", m.measured,
                                                     " of ", impl_->num_measured, " (SetMeasuredBrdfs)"));
    }
    needs_kd_texture |= m.kd_from_texture;
    gpu[i].base_amplitude = glm::vec4(m.kd.base, m.kd.amplitude);
    gpu[i].offset_frequency = glm::vec4(m.kd.offset, m.kd.frequency);
    gpu[i].ks_kd_from_texture =
        glm::vec4(m.measured >= 0 ? glm::vec3(m.measured_gain) : m.ks, m.kd_from_texture ? 1.0f : 0.0f);
    gpu[i].ke = glm::vec4(m.ke, m.measured >= 0 ? static_cast<float>(m.measured) : -1.0f);
    gpu[i].p3 = glm::vec4(m.p3, 0.0f);
  }
  glNamedBufferSubData(impl_->material_buffer.id(), 0, static_cast<GLsizeiptr>(gpu.size() * sizeof(GpuMaterial)),
                       gpu.data());
  impl_->needs_kd_texture = needs_kd_texture;
  impl_->mode = Impl::Mode::kProcedural;
  return gl::CheckGlError("SetProceduralMaterials");
}

absl::Status PhongRenderer::SetMeasuredBrdfs(const std::vector<brdf::NeuralBrdf>& brdfs) {
  std::vector<float> weights;
  for (const brdf::NeuralBrdf& b : brdfs) {
    const std::vector<float> w = b.GlslWeights();
    weights.insert(weights.end(), w.begin(), w.end());
  }
  if (weights.empty()) weights.assign(brdf::NeuralBrdf::kNumWeights, 0.0f);
  impl_->nbrdf_buffer = gl::CreateBuffer();
  glNamedBufferStorage(impl_->nbrdf_buffer.id(), static_cast<GLsizeiptr>(weights.size() * sizeof(float)),
                       weights.data(), 0);
  impl_->num_measured = brdfs.size();
  return gl::CheckGlError("SetMeasuredBrdfs");
}

absl::Status PhongRenderer::SetKdTexture(const cv::Mat& kd_linear) {
  MVBRDF_ASSIGN_OR_RETURN(impl_->kd_texture, UploadUvImage(kd_linear, "kd texture"));
  return absl::OkStatus();
}

absl::Status PhongRenderer::SetAtlasMaterials(const cv::Mat& kd, const cv::Mat& ks, const cv::Mat& ke,
                                             const cv::Mat& model, const cv::Mat& p3,
                                             const cv::Mat& ggx_support) {
  if (!impl_->has_uvs) return absl::FailedPreconditionError("atlas materials: the mesh has no uvs");
  gl::Texture model_texture;
  if (!model.empty()) {
    if (model.type() != CV_8UC1 || model.size() != kd.size()) {
      return absl::InvalidArgumentError(absl::StrCat("model atlas: expected CV_8UC1 of the kd atlas's size ",
                                                     kd.cols, "x", kd.rows, ", got type ", model.type(), " ",
                                                     model.cols, "x", model.rows));
    }
    cv::Mat as_float;
    model.convertTo(as_float, CV_32F);
    cv::Mat rgb;
    cv::merge(std::vector<cv::Mat>{as_float, as_float, as_float}, rgb);
    MVBRDF_ASSIGN_OR_RETURN(model_texture, UploadUvImage(rgb, "model atlas"));
  }
  MVBRDF_ASSIGN_OR_RETURN(gl::Texture kd_texture, UploadUvImage(kd, "kd atlas"));
  MVBRDF_ASSIGN_OR_RETURN(gl::Texture ks_texture, UploadUvImage(ks, "ks atlas"));
  MVBRDF_ASSIGN_OR_RETURN(gl::Texture ke_texture, UploadUvImage(ke, "ke atlas"));
  // No third parameter's atlas: GGX's dielectric ratio everywhere (the
  // models with two parameters do not read it).
  const cv::Mat dielectric(1, 1, CV_32FC3, cv::Scalar::all(brdf::Ggx::kDielectricRatio));
  MVBRDF_ASSIGN_OR_RETURN(gl::Texture p3_texture, UploadUvImage(p3.empty() ? dielectric : p3, "third parameter atlas"));
  gl::Texture support_texture;
  if (!ggx_support.empty()) {
    MVBRDF_ASSIGN_OR_RETURN(support_texture, UploadUvImage(ggx_support, "GGX grazing support atlas"));
  }
  impl_->atlas_kd = std::move(kd_texture);
  impl_->atlas_ks = std::move(ks_texture);
  impl_->atlas_ke = std::move(ke_texture);
  impl_->atlas_model = std::move(model_texture);
  impl_->atlas_p3 = std::move(p3_texture);
  impl_->atlas_ggx_support = std::move(support_texture);
  impl_->mode = Impl::Mode::kAtlas;
  return absl::OkStatus();
}

absl::Status PhongRenderer::SetNormalDetail(const NormalDetail& detail) {
  if (!std::isfinite(detail.amplitude) || detail.amplitude < 0.0f) {
    return absl::InvalidArgumentError(absl::StrCat("normal detail amplitude: must be finite and >= 0, got ",
                                                   detail.amplitude));
  }
  if (!(detail.wavelength > 0.0f) || !std::isfinite(detail.wavelength)) {
    return absl::InvalidArgumentError(absl::StrCat("normal detail wavelength: must be > 0, got ", detail.wavelength));
  }
  if (detail.amplitude > 0.0f && !impl_->has_uvs) {
    return absl::FailedPreconditionError("normal detail: the mesh has no uvs for its tangent frames");
  }
  impl_->normal_detail = detail;
  return absl::OkStatus();
}

absl::Status PhongRenderer::SetNormalAtlas(const cv::Mat& tangent_normals) {
  if (tangent_normals.empty()) {
    impl_->atlas_normal = gl::Texture();
    return absl::OkStatus();
  }
  if (!impl_->has_uvs) return absl::FailedPreconditionError("normal atlas: the mesh has no uvs");
  MVBRDF_ASSIGN_OR_RETURN(impl_->atlas_normal, UploadUvImage(tangent_normals, "normal atlas"));
  return absl::OkStatus();
}

absl::Status PhongRenderer::SetLights(const std::vector<scene::Light>& lights) {
  for (size_t k = 0; k < lights.size(); ++k) {
    if (lights[k].directional && !(glm::length(lights[k].direction) > 0.0f)) {
      return absl::InvalidArgumentError(absl::StrCat("lights[", k, "].direction: must be non-zero"));
    }
  }
  impl_->lights = lights;
  impl_->shadows_valid = false;  // the shadow maps are (re)allocated and rendered by the next PreparePose
  return absl::OkStatus();
}

absl::Status PhongRenderer::Impl::CheckContextAndPose(absl::string_view caller, const Pose& pose) const {
  if (!context->IsCurrent()) {
    return absl::FailedPreconditionError(
        absl::StrCat("PhongRenderer::", caller, ": the EGL context is not current on this thread"));
  }
  if (pose.positions.size() != num_vertices || pose.normals.size() != num_vertices) {
    return absl::InvalidArgumentError(absl::StrCat("pose: expected ", num_vertices,
                                                   " positions and normals (one per render vertex), got ",
                                                   pose.positions.size(), " and ", pose.normals.size()));
  }
  return absl::OkStatus();
}

absl::Status PhongRenderer::Impl::CheckMaterials(absl::string_view caller) const {
  if (mode == Mode::kNone) {
    return absl::FailedPreconditionError(absl::StrCat(
        "PhongRenderer::", caller, ": no materials; call SetProceduralMaterials or SetAtlasMaterials first"));
  }
  if (mode == Mode::kProcedural && needs_kd_texture && !kd_texture) {
    return absl::FailedPreconditionError(absl::StrCat(
        "PhongRenderer::", caller, ": a material takes kd from the texture but SetKdTexture was not called"));
  }
  return absl::OkStatus();
}

void PhongRenderer::Impl::PreparePose(const Pose& pose) {
  const GLsizeiptr vec3_bytes = static_cast<GLsizeiptr>(num_vertices * sizeof(glm::vec3));
  glNamedBufferSubData(position_buffer.id(), 0, vec3_bytes, pose.positions.data());
  glNamedBufferSubData(normal_buffer.id(), 0, vec3_bytes, pose.normals.data());
  if (NeedsTangents()) {
    const std::vector<glm::vec4> tangents = scene::VertexTangents(triangles, pose.positions, pose.normals, uvs);
    glNamedBufferSubData(tangent_buffer.id(), 0, static_cast<GLsizeiptr>(num_vertices * sizeof(glm::vec4)),
                         tangents.data());
  }
  bounds = ComputeBoundingSphere(pose.positions);
}

absl::Status PhongRenderer::Impl::PrepareLightPass(const Pose& pose, int pass) {
  if (shadows_valid && shadow_pass == pass && shadow_positions == pose.positions) return absl::OkStatus();
  shadows_valid = false;
  const size_t begin = static_cast<size_t>(pass) * kLightsPerPass;
  const size_t end = std::min(lights.size(), begin + kLightsPerPass);
  const std::vector<scene::Light> pass_lights(lights.begin() + static_cast<std::ptrdiff_t>(begin),
                                              lights.begin() + static_cast<std::ptrdiff_t>(end));
  MVBRDF_RETURN_IF_ERROR(shadow_maps->Render(pass_lights, bounds, [this] { Draw(); }));
  GpuLightBlock block{};
  block.count = glm::ivec4(static_cast<int>(pass_lights.size()), 0, 0, 0);
  for (size_t k = 0; k < pass_lights.size(); ++k) {
    const LightShadow& shadow = shadow_maps->light_shadows()[k];
    GpuLight& gpu = block.lights[k];
    gpu.position = shadow.position;
    gpu.intensity = glm::vec4(pass_lights[k].intensity, 0.0f);
    gpu.shadow = shadow.shadow;
    gpu.shadow_from_world = shadow.shadow_from_world;
  }
  glNamedBufferSubData(light_buffer.id(), 0, sizeof(GpuLightBlock), &block);
  shadow_positions = pose.positions;
  shadow_pass = pass;
  shadows_valid = true;
  return absl::OkStatus();
}

absl::Status PhongRenderer::Impl::DrawShaded(const Pose& pose, const glm::mat4& clip_from_world,
                                             const glm::vec4& camera_center, bool uv_space, RenderTarget& target) {
  // One light pass: the shadow maps stay valid across cameras. More: each
  // pass renders its own (GPU memory for 16 lights, whatever their number)
  // and the radiance is summed on the CPU (blending would also sum the
  // fragments of overlapping UV triangles); coverage is the first pass's.
  const int passes = NumLightPasses();
  for (int pass = 0; pass < passes; ++pass) {
    MVBRDF_RETURN_IF_ERROR(PrepareLightPass(pose, pass));
    MVBRDF_RETURN_IF_ERROR(
        DrawShadedPass(clip_from_world, camera_center, uv_space, target, pass == 0 ? &readback : &pass_readback));
    if (pass == 0) continue;
    for (size_t i = 0; i < readback.size(); i += 4) {
      for (size_t c = 0; c < 3; ++c) readback[i + c] += pass_readback[i + c];
    }
  }
  return absl::OkStatus();
}

absl::Status PhongRenderer::Impl::DrawShadedPass(const glm::mat4& clip_from_world, const glm::vec4& camera_center,
                                                 bool uv_space, RenderTarget& target, std::vector<float>* out) {
  const GLuint program = phong_program.id();
  glProgramUniformMatrix4fv(program, kClipFromWorldLocation, 1, GL_FALSE, glm::value_ptr(clip_from_world));
  glProgramUniform4fv(program, kCameraCenterLocation, 1, glm::value_ptr(camera_center));
  glProgramUniform1i(program, kAtlasModeLocation, mode == Mode::kAtlas ? 1 : 0);
  glProgramUniform1i(program, kFalloffLocation, options.inverse_square_falloff ? 1 : 0);
  const bool per_texel_model = mode == Mode::kAtlas && atlas_model;
  glProgramUniform1i(program, kBrdfModelLocation, per_texel_model ? -1 : static_cast<GLint>(options.brdf_model));
  glProgramUniform1i(program, kUvSpaceLocation, uv_space ? 1 : 0);
  const int normal_mode = mode == Mode::kAtlas ? (atlas_normal ? 2 : 0) : (normal_detail.amplitude != 0.0f ? 1 : 0);
  glProgramUniform1i(program, kNormalModeLocation, normal_mode);
  glProgramUniform4f(program, kNormalDetailLocation, normal_detail.amplitude, normal_detail.wavelength, 0.0f, 0.0f);
  glProgramUniform3fv(program, kNormalDetailD1Location, 1, glm::value_ptr(normal_detail.d1));
  glProgramUniform3fv(program, kNormalDetailD2Location, 1, glm::value_ptr(normal_detail.d2));

  const GLuint placeholder = placeholder_texture.id();
  const bool atlas = mode == Mode::kAtlas;
  glBindTextureUnit(kKdTextureUnit, kd_texture ? kd_texture.id() : placeholder);
  glBindTextureUnit(kAtlasKdUnit, atlas ? atlas_kd.id() : placeholder);
  glBindTextureUnit(kAtlasKsUnit, atlas ? atlas_ks.id() : placeholder);
  glBindTextureUnit(kAtlasKeUnit, atlas ? atlas_ke.id() : placeholder);
  glBindTextureUnit(kPointShadowUnit, shadow_maps->point_maps().id());
  glBindTextureUnit(kDirectionalShadowUnit, shadow_maps->directional_maps().id());
  glBindTextureUnit(kAtlasModelUnit, per_texel_model ? atlas_model.id() : placeholder);
  glBindTextureUnit(kAtlasP3Unit, atlas ? atlas_p3.id() : placeholder);
  glBindTextureUnit(kAtlasGgxSupportUnit, atlas && atlas_ggx_support ? atlas_ggx_support.id() : placeholder);
  glBindTextureUnit(kAtlasNormalUnit, atlas && atlas_normal ? atlas_normal.id() : placeholder);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kNbrdfWeightsBinding, nbrdf_buffer.id());
  glBindBufferBase(GL_UNIFORM_BUFFER, kLightBlockBinding, light_buffer.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kMaterialBlockBinding, material_buffer.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kTriangleMaterialBlockBinding, triangle_material_buffer.id());

  glBindFramebuffer(GL_FRAMEBUFFER, target.framebuffer.id());
  glViewport(0, 0, target.width, target.height);
  // In UV space every triangle lies at depth 0; there is nothing to resolve.
  if (uv_space) {
    glDisable(GL_DEPTH_TEST);
  } else {
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
  }
  glDisable(GL_CULL_FACE);
  glDisable(GL_BLEND);
  const float clear_color[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  const float clear_depth = 1.0f;
  glClearNamedFramebufferfv(target.framebuffer.id(), GL_COLOR, 0, clear_color);
  glClearNamedFramebufferfv(target.framebuffer.id(), GL_DEPTH, 0, &clear_depth);
  glUseProgram(program);
  Draw();

  // Read back in the target's own format (PERF.md: the fast path).
  out->resize(static_cast<size_t>(target.width) * target.height * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glPixelStorei(GL_PACK_ROW_LENGTH, 0);
  glReadPixels(0, 0, target.width, target.height, GL_RGBA, GL_FLOAT, out->data());
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glUseProgram(0);
  glBindVertexArray(0);
  return gl::CheckGlError("PhongRenderer: shading pass");
}

namespace {

// A positive size and focal lengths (pinhole) or pixel size (orthographic).
absl::Status CheckCameraScale(const scene::CameraModel& camera) {
  const bool scale_ok = camera.orthographic() ? camera.pixel_size > 0.0 && std::isfinite(camera.pixel_size)
                                              : camera.fx > 0.0 && camera.fy > 0.0;
  if (camera.width > 0 && camera.height > 0 && scale_ok) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat("camera \"", camera.name, "\": need positive size and ",
                   camera.orthographic() ? "pixel size" : "focal lengths", ", got ", camera.width, "x", camera.height,
                   camera.orthographic() ? absl::StrCat(", pixel size ", camera.pixel_size)
                                         : absl::StrCat(", fx ", camera.fx, ", fy ", camera.fy)));
}

}  // namespace

absl::StatusOr<RenderOutput> PhongRenderer::Render(const Pose& pose, const scene::CameraModel& camera) {
  Impl& r = *impl_;
  MVBRDF_RETURN_IF_ERROR(r.CheckContextAndPose("Render", pose));
  MVBRDF_RETURN_IF_ERROR(r.CheckMaterials("Render"));
  MVBRDF_RETURN_IF_ERROR(CheckCameraScale(camera));
  if (const int max_side = MaxTargetSide(); camera.width > max_side || camera.height > max_side) {
    return absl::InvalidArgumentError(absl::StrCat("camera \"", camera.name, "\": an image of ", camera.width, "x",
                                                   camera.height, " exceeds the largest render target, ", max_side,
                                                   " pixels a side (GL_MAX_RENDERBUFFER_SIZE)"));
  }
  r.PreparePose(pose);
  MVBRDF_RETURN_IF_ERROR(r.camera_target.Ensure(camera.width, camera.height, "render target"));
  const ClipRange clip = ClipRangeOf(camera, r.bounds.center, r.bounds.radius);
  const glm::dmat4 clip_from_world =
      ClipFromCamera(camera, clip.near_plane, clip.far_plane) * CamFromWorldMatrix(camera);
  // Window row 0 is image row 0 (see ClipFromCamera): no flip.
  MVBRDF_RETURN_IF_ERROR(r.DrawShaded(pose, glm::mat4(clip_from_world), glm::vec4(camera.ViewOrigin()),
                                      /*uv_space=*/false, r.camera_target));

  RenderOutput output;
  output.radiance.create(camera.height, camera.width, CV_32FC3);
  output.coverage.create(camera.height, camera.width, CV_8UC1);
  const float* src = r.readback.data();
  for (int y = 0; y < camera.height; ++y) {
    float* radiance = output.radiance.ptr<float>(y);
    uint8_t* coverage = output.coverage.ptr<uint8_t>(y);
    for (int x = 0; x < camera.width; ++x, src += 4) {
      radiance[3 * x + 0] = src[0];
      radiance[3 * x + 1] = src[1];
      radiance[3 * x + 2] = src[2];
      coverage[x] = src[3] > 0.5f ? 255 : 0;
    }
  }
  return output;
}

absl::StatusOr<cv::Mat> PhongRenderer::RenderAtlas(const Pose& pose, const glm::vec3& camera_center, int size) {
  return RenderAtlas(pose, glm::vec4(camera_center, 1.0f), size);
}

absl::StatusOr<cv::Mat> PhongRenderer::RenderAtlas(const Pose& pose, const scene::CameraModel& camera, int size) {
  return RenderAtlas(pose, glm::vec4(camera.ViewOrigin()), size);
}

absl::StatusOr<cv::Mat> PhongRenderer::RenderAtlas(const Pose& pose, const glm::vec4& camera_center, int size) {
  Impl& r = *impl_;
  MVBRDF_RETURN_IF_ERROR(r.CheckContextAndPose("RenderAtlas", pose));
  if (!r.has_uvs) {
    return absl::FailedPreconditionError(
        "PhongRenderer::RenderAtlas: the mesh has no uvs; RenderMesh::uvs must hold the atlas layout");
  }
  MVBRDF_RETURN_IF_ERROR(r.CheckMaterials("RenderAtlas"));
  const int max_side = MaxTargetSide();
  if (size < 1 || size > max_side) {
    return absl::InvalidArgumentError(absl::StrCat("size: must be in [1, ", max_side, "], got ", size));
  }
  if (!std::isfinite(camera_center.x) || !std::isfinite(camera_center.y) || !std::isfinite(camera_center.z) ||
      !std::isfinite(camera_center.w)) {
    return absl::InvalidArgumentError("camera_center: must be finite");
  }
  r.PreparePose(pose);
  MVBRDF_RETURN_IF_ERROR(r.atlas_target.Ensure(size, size, "atlas target"));
  MVBRDF_RETURN_IF_ERROR(r.DrawShaded(pose, glm::mat4(1.0f), camera_center, /*uv_space=*/true, r.atlas_target));

  // Window row 0 is v = 0, the atlas's bottom row: flip.
  cv::Mat atlas(size, size, CV_32FC4);
  const size_t row_floats = static_cast<size_t>(size) * 4;
  for (int j = 0; j < size; ++j) {
    const float* src = r.readback.data() + static_cast<size_t>(size - 1 - j) * row_floats;
    std::copy(src, src + row_floats, atlas.ptr<float>(j));
  }
  return atlas;
}

absl::StatusOr<cv::Mat> PhongRenderer::RenderTriangleIds(const Pose& pose, const scene::CameraModel& camera,
                                                         int supersample) {
  Impl& r = *impl_;
  MVBRDF_RETURN_IF_ERROR(r.CheckContextAndPose("RenderTriangleIds", pose));
  MVBRDF_RETURN_IF_ERROR(CheckCameraScale(camera));
  const int max_side = MaxTargetSide();
  if (supersample < 1 || static_cast<int64_t>(camera.width) * supersample > max_side ||
      static_cast<int64_t>(camera.height) * supersample > max_side) {
    return absl::InvalidArgumentError(absl::StrCat("supersample: must be >= 1 with the scaled image at most ", max_side,
                                                   " pixels a side; got ", supersample, " for camera \"", camera.name,
                                                   "\" of ", camera.width, "x", camera.height));
  }
  const scene::CameraModel scaled = scene::Supersampled(camera, supersample);

  glNamedBufferSubData(r.position_buffer.id(), 0, static_cast<GLsizeiptr>(r.num_vertices * sizeof(glm::vec3)),
                       pose.positions.data());
  RenderTarget& target = r.triangle_id_target;
  MVBRDF_RETURN_IF_ERROR(target.Ensure(scaled.width, scaled.height, "triangle-id target"));
  const BoundingSphere bounds = ComputeBoundingSphere(pose.positions);
  const ClipRange clip = ClipRangeOf(scaled, bounds.center, bounds.radius);
  const glm::mat4 clip_from_world(ClipFromCamera(scaled, clip.near_plane, clip.far_plane) * CamFromWorldMatrix(scaled));
  const GLuint program = r.triangle_id_program.id();
  glProgramUniformMatrix4fv(program, kClipFromWorldLocation, 1, GL_FALSE, glm::value_ptr(clip_from_world));
  glBindFramebuffer(GL_FRAMEBUFFER, target.framebuffer.id());
  glViewport(0, 0, scaled.width, scaled.height);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glDisable(GL_CULL_FACE);
  glDisable(GL_BLEND);
  const GLint no_triangle[4] = {-1, -1, -1, -1};
  const float clear_depth = 1.0f;
  glClearNamedFramebufferiv(target.framebuffer.id(), GL_COLOR, 0, no_triangle);
  glClearNamedFramebufferfv(target.framebuffer.id(), GL_DEPTH, 0, &clear_depth);
  glUseProgram(program);
  r.Draw();

  // Window row 0 is image row 0 (see ClipFromCamera): no flip.
  cv::Mat ids(scaled.height, scaled.width, CV_32SC1);  // continuous
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glPixelStorei(GL_PACK_ROW_LENGTH, 0);
  glReadPixels(0, 0, scaled.width, scaled.height, GL_RED_INTEGER, GL_INT, ids.data);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glUseProgram(0);
  glBindVertexArray(0);
  MVBRDF_RETURN_IF_ERROR(gl::CheckGlError("PhongRenderer::RenderTriangleIds"));
  return ids;
}

}  // namespace mvbrdf::render
