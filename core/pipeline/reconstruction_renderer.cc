#include "core/pipeline/reconstruction_renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "absl/strings/str_cat.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/image/exr.h"
#include "core/pipeline/run_atlases.h"
#include "core/scene/ray_triangle.h"
#include "core/synth/frame_encoder.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::pipeline {
namespace {

absl::StatusOr<cv::Mat> ReadRgb(const std::filesystem::path& file) {
  MVBRDF_ASSIGN_OR_RETURN(image::ExrImage exr, image::ReadExr(file));
  if (exr.image.type() != CV_32FC3) return absl::InvalidArgumentError(absl::StrCat(file.string(), ": expected RGB"));
  return exr.image;
}

// Bilinear lookup of an atlas image (row 0 = v 1; texel (i, j) centred at
// u = (i + 0.5) / size, v = 1 - (j + 0.5) / size), edges clamped, as GL's
// linear filtering of the renderer's textures.
cv::Vec3f SampleAtlas(const cv::Mat& atlas, glm::dvec2 uv) {
  const double x = uv.x * atlas.cols - 0.5;
  const double y = (1.0 - uv.y) * atlas.rows - 0.5;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const auto at = [&](int xi, int yi) {
    return atlas.at<cv::Vec3f>(std::clamp(yi, 0, atlas.rows - 1), std::clamp(xi, 0, atlas.cols - 1));
  };
  return (at(x0, y0) * (1 - fx) + at(x0 + 1, y0) * fx) * (1 - fy) +
         (at(x0, y0 + 1) * (1 - fx) + at(x0 + 1, y0 + 1) * fx) * fy;
}

// Calls visit(x, y, uv) for every pixel the undistorted image's triangle ids
// cover, uv the surface point's atlas coordinate: the pixel's ray (pinhole:
// through its centre from the camera centre; orthographic: along +z) meets
// its triangle at barycentric (a, b, c), whose UVs give it.
template <typename Visit>
void ForEachPixelUv(const cv::Mat& triangle_ids, const scene::CameraModel& camera, const render::RenderMesh& mesh,
                    const render::Pose& pose, Visit visit) {
  // The pose in camera coordinates, once (not three vertices per pixel).
  std::vector<glm::dvec3> in_camera(pose.positions.size());
  for (size_t v = 0; v < in_camera.size(); ++v) in_camera[v] = camera.CamFromWorld(glm::dvec3(pose.positions[v]));
  for (int y = 0; y < triangle_ids.rows; ++y) {
    for (int x = 0; x < triangle_ids.cols; ++x) {
      const int id = triangle_ids.at<int32_t>(y, x);
      if (id < 0) continue;
      const glm::uvec3 tri = mesh.triangles[static_cast<size_t>(id)];
      const glm::dvec3 p[3] = {in_camera[tri[0]], in_camera[tri[1]], in_camera[tri[2]]};
      glm::dvec3 origin(0.0), direction;
      if (camera.orthographic()) {
        origin = glm::dvec3((x - camera.cx) * camera.pixel_size, (y - camera.cy) * camera.pixel_size, 0.0);
        direction = glm::dvec3(0.0, 0.0, 1.0);
      } else {
        direction = glm::dvec3((x - camera.cx) / camera.fx, (y - camera.cy) / camera.fy, 1.0);
      }
      const std::optional<scene::RayTriangleHit> hit = scene::IntersectRayTriangle(origin, direction, p[0], p[1], p[2]);
      if (!hit) continue;
      const double b = hit->b1, c = hit->b2;
      const double bc = std::clamp(b, 0.0, 1.0), cc = std::clamp(c, 0.0, 1.0 - bc);
      const glm::dvec2 uv = glm::dvec2(mesh.uvs[tri[0]]) * (1.0 - bc - cc) + glm::dvec2(mesh.uvs[tri[1]]) * bc +
                            glm::dvec2(mesh.uvs[tri[2]]) * cc;
      visit(x, y, uv);
    }
  }
}

}  // namespace

absl::StatusOr<std::unique_ptr<ReconstructionRenderer>> ReconstructionRenderer::Open(
    const std::filesystem::path& run_dir, const scene::Sequence& sequence, gl::EglContext& context,
    bool grazing_support) {
  MVBRDF_ASSIGN_OR_RETURN(const v1::RunReport run, ReadJsonFileAs<v1::RunReport>(run_dir / "result.json"));
  MVBRDF_ASSIGN_OR_RETURN(atlas::Atlas atlas, OpenRunAtlas(run_dir, run, sequence));
  MVBRDF_ASSIGN_OR_RETURN(RunAtlases atlases, ReadRunAtlases(run_dir, run));
  auto r = std::unique_ptr<ReconstructionRenderer>(new ReconstructionRenderer(run_dir, sequence, std::move(atlas)));
  const brdf::Model model = atlases.model;
  r->kd_ = atlases.kd;
  r->ks_ = atlases.p1;
  r->ke_ = atlases.p2;
  r->p3_ = atlases.p3;
  r->model_ = atlases.model_atlas;
  r->confidence_ = atlases.confidence;
  // GGX's lobes not extrapolated towards grazing past what the capture saw.
  if (grazing_support) {
    MVBRDF_ASSIGN_OR_RETURN(r->ggx_support_, GgxSupportAtlas(run_dir, run, atlases.kd.rows));
  }
  render::RenderMesh& mesh = r->mesh_;
  mesh.triangles = r->atlas_.topology.triangles;
  mesh.uvs = r->atlas_.topology.uvs;
  mesh.rest_positions = scene::ToRenderVertices(r->atlas_.topology, sequence.rest_positions);
  render::RendererOptions renderer_options;
  renderer_options.brdf_model = model;
  // The scene's light fall-off, as the fit assumed it (scene.lighting).
  renderer_options.inverse_square_falloff = sequence.scene.lighting().inverse_square_falloff();
  MVBRDF_ASSIGN_OR_RETURN(r->renderer_, render::PhongRenderer::Create(context, mesh, renderer_options));
  MVBRDF_RETURN_IF_ERROR(r->renderer_->SetAtlasMaterials(r->kd_, r->ks_, r->ke_, r->model_, r->p3_, r->ggx_support_));
  // Issue #18: a run with refined normals is drawn with them.
  if (std::filesystem::exists(run_dir / "atlases" / "normal.exr")) {
    MVBRDF_ASSIGN_OR_RETURN(const cv::Mat normal, ReadRgb(run_dir / "atlases" / "normal.exr"));
    MVBRDF_RETURN_IF_ERROR(r->renderer_->SetNormalAtlas(normal));
  }
  return r;
}

absl::StatusOr<cv::Mat> ReconstructionRenderer::Render(const scene::CameraModel& camera,
                                                       const std::vector<scene::Light>& lights, int frame,
                                                       bool correction) {
  return Render(camera, lights, frame, correction, Extras());
}

absl::StatusOr<cv::Mat> ReconstructionRenderer::Render(const scene::CameraModel& camera,
                                                       const std::vector<scene::Light>& lights, int frame,
                                                       bool correction, const Extras& extras) {
  if (frame < 0 || frame >= sequence_.num_frames) {
    return absl::InvalidArgumentError(absl::StrCat("frame: must be in [0, ", sequence_.num_frames, "), got ", frame));
  }
  if (correction) {
    char name[32];
    std::snprintf(name, sizeof(name), "%04d.exr", sequence_.AbsoluteFrame(frame));
    MVBRDF_ASSIGN_OR_RETURN(const cv::Mat c, ReadRgb(run_dir_ / "atlases" / "correction" / name));
    corrected_kd_ = kd_ + c;
    MVBRDF_RETURN_IF_ERROR(renderer_->SetAtlasMaterials(corrected_kd_, ks_, ke_, model_, p3_, ggx_support_));  // render with kd + c
    with_correction_ = true;
  } else if (with_correction_) {
    MVBRDF_RETURN_IF_ERROR(renderer_->SetAtlasMaterials(kd_, ks_, ke_, model_, p3_, ggx_support_));
    with_correction_ = false;
  }
  MVBRDF_RETURN_IF_ERROR(renderer_->SetLights(lights));
  MVBRDF_ASSIGN_OR_RETURN(const scene::FramePositions positions, sequence_.LoadFrame(frame));
  render::Pose pose;
  pose.positions = scene::ToRenderVertices(atlas_.topology, positions);
  pose.normals = scene::ToRenderVertices(atlas_.topology, scene::ComputeFileVertexNormals(atlas_.topology, positions));
  MVBRDF_ASSIGN_OR_RETURN(render::RenderOutput image, renderer_->Render(pose, camera));
  cv::Mat ids;
  if (extras.ambient != glm::vec3(0.0f) || extras.observed != nullptr) {
    MVBRDF_ASSIGN_OR_RETURN(ids, renderer_->RenderTriangleIds(pose, camera, 1));
  }
  if (extras.ambient != glm::vec3(0.0f)) {
    // kd * ambient at every covered pixel's surface point.
    const cv::Mat& kd = correction ? corrected_kd_ : kd_;
    const glm::vec3 ambient = extras.ambient;
    ForEachPixelUv(ids, camera, mesh_, pose, [&](int x, int y, const glm::dvec2& uv) {
      const cv::Vec3f k = SampleAtlas(kd, uv);
      image.radiance.at<cv::Vec3f>(y, x) += cv::Vec3f(k[0] * ambient.x, k[1] * ambient.y, k[2] * ambient.z);
    });
  }
  if (extras.observed != nullptr) {
    cv::Mat observed(image.radiance.size(), CV_8UC1, cv::Scalar(0));
    ForEachPixelUv(ids, camera, mesh_, pose, [&](int x, int y, const glm::dvec2& uv) {
      const int i = std::clamp(static_cast<int>(std::floor(uv.x * confidence_.cols)), 0, confidence_.cols - 1);
      const int j = std::clamp(static_cast<int>(std::floor((1.0 - uv.y) * confidence_.rows)), 0, confidence_.rows - 1);
      if (confidence_.at<float>(j, i) > 0.0f) observed.at<uint8_t>(y, x) = 255;
    });
    *extras.observed = observed;
  }
  if (extras.coverage != nullptr) {
    cv::Mat coverage;
    image.coverage.convertTo(coverage, CV_32FC1, 1.0 / 255.0);
    *extras.coverage = synth::ApplyDistortion(coverage, camera);
  }
  return synth::ApplyDistortion(image.radiance, camera);
}

}  // namespace mvbrdf::pipeline
