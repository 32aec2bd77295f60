// Forward renderer of the extended Phong model (core/render/phong_model.h) on
// the GPU through an EglContext, with shadow maps per light (cube depth maps
// for point lights, an orthographic depth map for directional lights),
// smooth per-vertex normals and per-fragment BRDF parameters from either
// procedural materials (solid textures in rest-pose coordinates, optional kd
// from a UV texture) or UV-space atlases of kd, ks, ke.
//
// Threading: every call must come from the thread on which `context` is
// current. The renderer does not own the context; the context must outlive it.
#ifndef MVBRDF_CORE_RENDER_PHONG_RENDERER_H_
#define MVBRDF_CORE_RENDER_PHONG_RENDERER_H_

#include <glm/glm.hpp>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/statusor.h"
#include "core/brdf/ggx.h"
#include "core/brdf/model.h"
#include "core/brdf/nbrdf.h"
#include "core/gl/egl_context.h"
#include "core/render/normal_detail.h"
#include "core/render/solid_texture.h"
#include "core/scene/camera_model.h"
#include "core/scene/light.h"

namespace mvbrdf::render {

// Geometry that does not change from frame to frame, in render vertices.
struct RenderMesh {
  std::vector<glm::uvec3> triangles;
  std::vector<glm::vec2> uvs;               // per render vertex; may be empty unless a UV texture is used
  std::vector<glm::vec3> rest_positions;    // per render vertex; solid-texture coordinates
  std::vector<uint32_t> triangle_material;  // per triangle, index into the materials
};

struct ProceduralMaterial {
  SolidTextureParams kd;
  // Take kd from the UV texture given to SetKdTexture instead of `kd`.
  bool kd_from_texture = false;
  glm::vec3 ks{0.0f};
  glm::vec3 ke{1.0f};
  // The model's third parameter (GGX's f90_ratio; a dielectric's 25 unless
  // set; the two-parameter models do not read it).
  glm::vec3 p3{static_cast<float>(brdf::Ggx::kDielectricRatio)};
  // >= 0: the material is measured BRDF number `measured` of
  // SetMeasuredBrdfs' list (issue #15), drawn as rho(l, v) n.l I (rho in 1/sr,
  // core/brdf/nbrdf.h; the analytic models' specular term has the same
  // units), times `measured_gain`; kd, ks and ke are then unused.
  int measured = -1;
  float measured_gain = 1.0f;
};

struct RendererOptions {
  int shadow_map_size = 1024;  // texels per cube face / directional map side
  bool inverse_square_falloff = false;
  // The reflectance model (issue #15): the thesis's Phong by default; with
  // another, the materials' and atlases' ks and ke hold that model's two
  // parameters (brdf::ParameterNames: Blinn-Phong's ks, ke; GGX's f0,
  // roughness), the term as core/fit/lobe_fit.h evaluates it.
  brdf::Model brdf_model = brdf::Model::kPhong;
  // No clip planes to set: near and far come from each pose's bounding
  // sphere and the camera (ClipRangeOf in camera_projection.h), so a scene of
  // any world scale draws alike.
};

// One frame's pose: per render vertex positions and unit normals, world units.
struct Pose {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;
};

struct RenderOutput {
  // CV_32FC3, linear radiance, row 0 = top, pixel (x, y) = image pixel (x, y)
  // of camera_model.Project(); background 0. Channel order is R, G, B (not
  // OpenCV's usual B, G, R): convert before cv::imwrite.
  cv::Mat radiance;
  cv::Mat coverage;  // CV_8UC1, 255 where the mesh covers the pixel centre, else 0
};

class PhongRenderer {
 public:
  static absl::StatusOr<std::unique_ptr<PhongRenderer>> Create(gl::EglContext& context, const RenderMesh& mesh,
                                                               const RendererOptions& options);
  ~PhongRenderer();
  PhongRenderer(const PhongRenderer&) = delete;
  PhongRenderer& operator=(const PhongRenderer&) = delete;

  // The last of SetProceduralMaterials / SetAtlasMaterials chooses the mode.
  // Procedural mode. 1 to 64 materials, covering every id in
  // mesh.triangle_material (empty: all triangles use material 0).
  absl::Status SetProceduralMaterials(const std::vector<ProceduralMaterial>& materials);
  // The measured BRDFs procedural materials may name (ProceduralMaterial::
  // measured); replaces any earlier list. A material naming one past the
  // list's end is refused by SetProceduralMaterials.
  absl::Status SetMeasuredBrdfs(const std::vector<brdf::NeuralBrdf>& brdfs);
  // Linear RGB CV_32FC3 texture in UV space, row 0 = v = 1 (image convention).
  absl::Status SetKdTexture(const cv::Mat& kd_linear);
  // Atlas mode: kd, ks, ke as CV_32FC3 images in UV space (row 0 = v = 1),
  // ks and ke the two parameters of RendererOptions::brdf_model; or, with
  // `model` (CV_8UC1, the atlases' size: brdf::Model's value per texel, read
  // without filtering), of each texel's own model (`--brdf auto`). `p3`
  // (CV_32FC3 like ks, may be empty: GGX's dielectric ratio 25) holds the
  // third parameter of the models that have one (GGX's f90_ratio).
  // `ggx_support` (CV_32FC3 like ks, its red channel read; may be empty: 0
  // everywhere) holds per texel the grazing support GGX is drawn within
  // (brdf::Ggx::SpecularWithin, core/fit/grazing_support.h); 0 draws the
  // plain lobe. Procedural materials (the truth) are always drawn plain.
  absl::Status SetAtlasMaterials(const cv::Mat& kd, const cv::Mat& ks, const cv::Mat& ke,
                                 const cv::Mat& model = cv::Mat(), const cv::Mat& p3 = cv::Mat(),
                                 const cv::Mat& ggx_support = cv::Mat());

  // Issue #18. Procedural mode: the materials' surface detail (a
  // tangent-space normal per rest position, render/normal_detail.h; amplitude
  // 0: none). Atlas mode: tangent-space unit normals per texel as CV_32FC3 in
  // UV space (row 0 = v = 1; empty: the mesh's normals). Both read in the
  // tangent frames of the mesh's UVs (scene/tangent_frames.h, computed per
  // pose), so the mesh needs uvs (FAILED_PRECONDITION).
  absl::Status SetNormalDetail(const NormalDetail& detail);
  absl::Status SetNormalAtlas(const cv::Mat& tangent_normals);

  // Any number of lights, drawn in passes of 16 whose radiance is summed;
  // each light gets a shadow map. With at most 16 lights the maps are
  // rendered by Render whenever the lights or the pose's positions changed
  // since the last Render (so one pose seen from several cameras costs the
  // shadow passes once); with more, every Render renders each pass's maps
  // (GPU memory for 16 lights' maps, whatever their number).
  absl::Status SetLights(const std::vector<scene::Light>& lights);

  // Renders the pose from the camera as an undistorted pinhole (or
  // orthographic) image with the camera's size and intrinsics (distortion is applied by the caller, e.g.
  // synth, with a remap). Changes the context's bindings (framebuffer,
  // program, textures, buffers); it leaves none of its objects bound that a
  // caller could rely on.
  absl::StatusOr<RenderOutput> Render(const Pose& pose, const scene::CameraModel& camera);

  // The true radiance at each atlas texel's surface point: the mesh drawn at
  // its UVs (which must be the atlas layout; FAILED_PRECONDITION if the mesh
  // has no uvs) into a size x size target, every texel shaded exactly as
  // Render shades a fragment (same materials, the pose's shadow maps, the
  // same model) with v = normalize(camera_center - surface point), world
  // units. The surface point of a texel is its centre mapped affinely through
  // the covering triangle's UVs.
  //
  // Returns CV_32FC4 in the atlas image convention (core/atlas/atlas.h: row 0
  // at the top = v 1; texel (i, j) centred at u = (i + 0.5) / size,
  // v = 1 - (j + 0.5) / size): R, G, B = linear radiance, A = 1 where a
  // triangle covers the texel centre, else 0 (and R, G, B = 0). Where UVs
  // overlap, the triangle later in RenderMesh::triangles wins. size in
  // [1, the GL renderbuffer limit]. Shares the shadow-map cache with Render;
  // the same binding caveats apply.
  absl::StatusOr<cv::Mat> RenderAtlas(const Pose& pose, const glm::vec3& camera_center, int size);
  // The same seen from `camera` (pinhole or orthographic: v as
  // scene::CameraModel::ViewDirection), or from a homogeneous viewpoint
  // (CameraModel::ViewOrigin: w = 1 a centre, w = 0 a constant direction).
  absl::StatusOr<cv::Mat> RenderAtlas(const Pose& pose, const scene::CameraModel& camera, int size);
  absl::StatusOr<cv::Mat> RenderAtlas(const Pose& pose, const glm::vec4& camera_center, int size);

  // Visibility truth: the index into RenderMesh::triangles of the triangle
  // visible at every pixel centre of the camera's undistorted pinhole image
  // rendered at `supersample` times its resolution (width * s by height * s,
  // intrinsics f * s and (c + 0.5) * s - 0.5, so that pixel block
  // [s x, s x + s) x [s y, s y + s) covers camera pixel (x, y)); depth-tested
  // with near and far planes around the pose (ClipRangeOf). CV_32SC1, row 0 at the top,
  // -1 where no triangle is. Needs no materials or lights. supersample >= 1
  // and the scaled size within the GL renderbuffer limit.
  absl::StatusOr<cv::Mat> RenderTriangleIds(const Pose& pose, const scene::CameraModel& camera, int supersample);

 private:
  struct Impl;
  explicit PhongRenderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mvbrdf::render

#endif  // MVBRDF_CORE_RENDER_PHONG_RENDERER_H_
