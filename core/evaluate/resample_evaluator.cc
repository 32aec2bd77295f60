#include "core/evaluate/resample_evaluator.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"

namespace mvbrdf::evaluate {

void ResampleTally::Add(const ResampleTally& o) {
  covered += o.covered;
  valid += o.valid;
  truly_visible += o.truly_visible;
  valid_and_visible += o.valid_and_visible;
  sum_sq_valid += o.sum_sq_valid;
  sum_abs_valid += o.sum_abs_valid;
  sum_sq_valid_and_visible += o.sum_sq_valid_and_visible;
}

void ResampleTally::ToFigures(bool with_truth, v1::CameraFigures* f) const {
  f->set_covered_texels(covered);
  f->set_valid_texels(valid);
  f->set_valid_fraction(covered > 0 ? static_cast<double>(valid) / static_cast<double>(covered) : 0.0);
  if (!with_truth) return;
  f->set_truly_visible_texels(truly_visible);
  f->set_recall(truly_visible > 0 ? static_cast<double>(valid_and_visible) / static_cast<double>(truly_visible) : 0.0);
  f->set_false_valid_fraction(valid > 0 ? static_cast<double>(valid - valid_and_visible) / static_cast<double>(valid)
                                        : 0.0);
  // Averaged over the three channels, as the thesis's errors are.
  f->set_rmse(valid > 0 ? std::sqrt(sum_sq_valid / (3.0 * static_cast<double>(valid))) : 0.0);
  f->set_mean_abs_error(valid > 0 ? sum_abs_valid / (3.0 * static_cast<double>(valid)) : 0.0);
  f->set_rmse_truly_visible(valid_and_visible > 0
                                ? std::sqrt(sum_sq_valid_and_visible / (3.0 * static_cast<double>(valid_and_visible)))
                                : 0.0);
}

ResampleTally CountValid(const cv::Mat& resampled, const atlas::Atlas& atlas) {
  ResampleTally tally;
  for (int y = 0; y < atlas.size; ++y) {
    const int32_t* ids = atlas.triangle_id.ptr<int32_t>(y);
    const cv::Vec4f* px = resampled.ptr<cv::Vec4f>(y);
    for (int x = 0; x < atlas.size; ++x) {
      if (ids[x] < 0) continue;
      ++tally.covered;
      if (px[x][3] > 0.5f) ++tally.valid;
    }
  }
  return tally;
}

absl::StatusOr<std::unique_ptr<ResampleEvaluator>> ResampleEvaluator::Create(
    gl::EglContext& context, const synth::GroundTruth& truth, const atlas::Atlas& atlas,
    const scene::FramePositions& rest_positions, const resample::ResamplerOptions& options) {
  const v1::GroundTruth& message = truth.message();
  if (message.triangle_materials_size() != static_cast<int>(atlas.topology.triangles.size())) {
    return absl::FailedPreconditionError(absl::StrCat("ground truth: triangle_materials has ",
                                                      message.triangle_materials_size(), " entries, the mesh has ",
                                                      atlas.topology.triangles.size(), " triangles"));
  }
  if (message.cameras_size() == 0) return absl::FailedPreconditionError("ground truth: no cameras");
  std::unique_ptr<ResampleEvaluator> e(new ResampleEvaluator());
  e->atlas_ = &atlas;
  e->true_cameras_ = truth.Cameras();
  e->options_ = options;

  render::RenderMesh mesh;
  mesh.triangles = atlas.topology.triangles;
  mesh.uvs = atlas.topology.uvs;
  mesh.rest_positions = scene::ToRenderVertices(atlas.topology, rest_positions);
  mesh.triangle_material.assign(message.triangle_materials().begin(), message.triangle_materials().end());
  render::RendererOptions renderer_options;
  renderer_options.shadow_map_size = message.shadow_map_size() > 0 ? static_cast<int>(message.shadow_map_size()) : 1024;
  renderer_options.inverse_square_falloff = message.inverse_square_falloff();
  renderer_options.brdf_model = truth.Model();
  MVBRDF_ASSIGN_OR_RETURN(e->renderer_, render::PhongRenderer::Create(context, mesh, renderer_options));
  MVBRDF_RETURN_IF_ERROR(e->renderer_->SetMeasuredBrdfs(truth.MeasuredBrdfs()));
  MVBRDF_RETURN_IF_ERROR(e->renderer_->SetProceduralMaterials(truth.RendererMaterials()));
  if (!truth.KdTexture().empty()) MVBRDF_RETURN_IF_ERROR(e->renderer_->SetKdTexture(truth.KdTexture()));
  e->all_lights_ = truth.ActiveLights();
  MVBRDF_RETURN_IF_ERROR(e->renderer_->SetLights(e->all_lights_));
  for (const v1::FrameLighting& fl : message.frame_lighting()) {
    e->frame_lights_[fl.frame()] = truth.FrameLights(fl.frame());
  }

  return e;
}

absl::Status ResampleEvaluator::SetFrame(const scene::FramePositions& file_positions, uint32_t frame) {
  if (!frame_lights_.empty()) {
    const auto it = frame_lights_.find(frame);
    MVBRDF_RETURN_IF_ERROR(renderer_->SetLights(it != frame_lights_.end() ? it->second : all_lights_));
  }
  const scene::MeshTopology& topo = atlas_->topology;
  pose_.positions = scene::ToRenderVertices(topo, file_positions);
  pose_.normals = scene::ToRenderVertices(topo, scene::ComputeFileVertexNormals(topo, file_positions));
  return absl::OkStatus();
}

double ResampleEvaluator::RayTriangle(const glm::dvec3& origin, const glm::dvec3& dir, uint32_t triangle) const {
  // Moller-Trumbore in double precision on the posed triangle.
  const glm::uvec3 t = atlas_->topology.triangles[triangle];
  const glm::dvec3 a(pose_.positions[t.x]), b(pose_.positions[t.y]), c(pose_.positions[t.z]);
  const glm::dvec3 e1 = b - a, e2 = c - a;
  const glm::dvec3 h = glm::cross(dir, e2);
  const double det = glm::dot(e1, h);
  if (std::abs(det) < 1e-18) return std::numeric_limits<double>::infinity();
  const double inv = 1.0 / det;
  const glm::dvec3 sv = origin - a;
  const double u = inv * glm::dot(sv, h);
  if (u < 0.0 || u > 1.0) return std::numeric_limits<double>::infinity();
  const glm::dvec3 q = glm::cross(sv, e1);
  const double v = inv * glm::dot(dir, q);
  if (v < 0.0 || u + v > 1.0) return std::numeric_limits<double>::infinity();
  const double distance = inv * glm::dot(e2, q);
  return distance > 0.0 ? distance : std::numeric_limits<double>::infinity();
}

absl::StatusOr<ResampleTally> ResampleEvaluator::Evaluate(int camera, const cv::Mat& resampled,
                                                          const resample::GeometryAtlas& geometry) {
  if (camera < 0 || camera >= static_cast<int>(true_cameras_.size())) {
    return absl::OutOfRangeError(absl::StrCat("ground truth has no camera ", camera));
  }
  const scene::CameraModel& cam = true_cameras_[camera];
  MVBRDF_ASSIGN_OR_RETURN(const cv::Mat truth, renderer_->RenderAtlas(pose_, cam, atlas_->size));
  MVBRDF_ASSIGN_OR_RETURN(const cv::Mat ids, renderer_->RenderTriangleIds(pose_, cam, kIdSupersample));
  const double min_cos = std::sin(options_.grazing_margin_deg * 3.14159265358979 / 180.0);
  const double s = kIdSupersample;

  ResampleTally tally;
  for (int y = 0; y < atlas_->size; ++y) {
    const int32_t* tri = atlas_->triangle_id.ptr<int32_t>(y);
    const cv::Vec4f* res = resampled.ptr<cv::Vec4f>(y);
    const cv::Vec4f* tru = truth.ptr<cv::Vec4f>(y);
    const cv::Vec4f* pos = geometry.position.ptr<cv::Vec4f>(y);
    const cv::Vec4f* nor = geometry.normal.ptr<cv::Vec4f>(y);
    for (int x = 0; x < atlas_->size; ++x) {
      if (tri[x] < 0) continue;
      ++tally.covered;
      const bool valid = res[x][3] > 0.5f;
      bool visible = false;
      if (pos[x][3] > 0.0f) {
        const glm::dvec3 p(pos[x][0], pos[x][1], pos[x][2]);
        const glm::dvec3 n(nor[x][0], nor[x][1], nor[x][2]);
        const glm::dvec3 in_cam = cam.CamFromWorld(p);
        const glm::dvec2 pixel = cam.Project(p);
        const glm::dvec3 v = cam.ViewDirection(p);
        const bool facing = glm::dot(n, v) > min_cos;
        const bool inside = in_cam.z > 0.0 && pixel.x >= 0.0 && pixel.y >= 0.0 && pixel.x <= cam.width - 1.0 &&
                            pixel.y <= cam.height - 1.0;
        if (facing && inside) {
          // Pinhole position in the supersampled id buffer; the triangles seen
          // within +-1 id pixel (a quarter camera pixel) are the candidate
          // occluders, and the point is visible when none of them crosses the
          // camera ray in front of it (exact ray-triangle test). The id buffer
          // only names the front surfaces; the decision is geometric, so thin
          // foreshortened triangles near silhouettes do not count as occluders.
          const glm::dvec2 undistorted = cam.ProjectUndistorted(p);
          const double px = (undistorted.x + 0.5) * s - 0.5;
          const double py = (undistorted.y + 0.5) * s - 0.5;
          const int ix = static_cast<int>(std::lround(px));
          const int iy = static_cast<int>(std::lround(py));
          // The camera ray through p: from the centre (pinhole), or from the
          // plane z = 0 along the axis (orthographic).
          const double distance = cam.orthographic() ? in_cam.z : glm::length(p - cam.CenterInWorld());
          const glm::dvec3 center = p + distance * v;
          const glm::dvec3 dir = -v;
          visible = true;
          for (int dy = -1; dy <= 1 && visible; ++dy) {
            for (int dx = -1; dx <= 1 && visible; ++dx) {
              const int qx = std::clamp(ix + dx, 0, ids.cols - 1), qy = std::clamp(iy + dy, 0, ids.rows - 1);
              const int32_t seen = ids.at<int32_t>(qy, qx);
              if (seen < 0 || seen == tri[x]) continue;
              const double hit = RayTriangle(center, dir, static_cast<uint32_t>(seen));
              if (hit < distance * (1.0 - kOcclusionRelativeEpsilon)) visible = false;
            }
          }
        }
      }
      if (visible) ++tally.truly_visible;
      if (!valid) continue;
      ++tally.valid;
      if (visible) ++tally.valid_and_visible;
      double sq = 0.0, abs_sum = 0.0;
      for (int c = 0; c < 3; ++c) {
        const double d = static_cast<double>(res[x][c]) - static_cast<double>(tru[x][c]);
        sq += d * d;
        abs_sum += std::abs(d);
      }
      tally.sum_sq_valid += sq;
      tally.sum_abs_valid += abs_sum;
      if (visible) tally.sum_sq_valid_and_visible += sq;
    }
  }
  return tally;
}

}  // namespace mvbrdf::evaluate
