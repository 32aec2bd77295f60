#include "core/pipeline/relighting_evaluation.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/pipeline/reconstruction_renderer.h"
#include "core/render/phong_renderer.h"
#include "core/render/shadow_maps.h"
#include "core/scene/mesh.h"

namespace mvbrdf::pipeline {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The scene's up axis. A camera without roll has a horizontal x axis, so up
// is normal to every camera's x axis: the sum of the cross products of pairs
// of x axes, each signed to agree with the cameras' mean up (-y in the camera
// frame), which is the answer when the x axes are all parallel (one camera,
// or all facing one way); world +y when even that cancels out.
glm::dvec3 UpAxis(const std::vector<scene::CameraModel>& cameras) {
  glm::dvec3 mean_up(0.0);
  std::vector<glm::dvec3> x_axes;
  for (const scene::CameraModel& c : cameras) {
    // The camera's axes in the world: the rows of cam_from_world (R^T e_i).
    const glm::dmat3& r = c.cam_from_world_rotation;
    mean_up -= glm::dvec3(r[0][1], r[1][1], r[2][1]);
    x_axes.emplace_back(r[0][0], r[1][0], r[2][0]);
  }
  if (!(glm::length(mean_up) > 1e-9)) mean_up = glm::dvec3(0.0, 1.0, 0.0);
  glm::dvec3 up(0.0);
  for (size_t i = 0; i < x_axes.size(); ++i) {
    for (size_t j = i + 1; j < x_axes.size(); ++j) {
      const glm::dvec3 n = glm::cross(x_axes[i], x_axes[j]);
      up += glm::dot(n, mean_up) >= 0.0 ? n : -n;
    }
  }
  return glm::length(up) > 1e-6 ? glm::normalize(up) : glm::normalize(mean_up);
}

// Rotation by `angle` (radians) about the unit `axis`.
glm::dmat3 Rotation(const glm::dvec3& axis, double angle) {
  const double c = std::cos(angle), s = std::sin(angle), t = 1.0 - c;
  const glm::dvec3& a = axis;
  // Column-major: m[col][row].
  return glm::dmat3(t * a.x * a.x + c, t * a.x * a.y + s * a.z, t * a.x * a.z - s * a.y,
                    t * a.x * a.y - s * a.z, t * a.y * a.y + c, t * a.y * a.z + s * a.x,
                    t * a.x * a.z + s * a.y, t * a.y * a.z - s * a.x, t * a.z * a.z + c);
}

// The signed angle from a to b about `up`, both projected on the plane
// normal to it.
double AngleAbout(const glm::dvec3& up, glm::dvec3 a, glm::dvec3 b) {
  a -= glm::dot(a, up) * up;
  b -= glm::dot(b, up) * up;
  if (glm::length(a) < 1e-12 || glm::length(b) < 1e-12) return 0.0;
  return std::atan2(glm::dot(glm::cross(a, b), up), glm::dot(a, b));
}

glm::dvec3 Centre(const std::vector<glm::vec3>& pose) {
  return glm::dvec3(render::ComputeBoundingSphere(pose).center);
}

}  // namespace

std::vector<scene::CameraModel> HeldOutViews(const scene::Sequence& sequence, const std::vector<glm::vec3>& pose,
                                             int count) {
  std::vector<scene::CameraModel> out;
  const std::vector<scene::CameraModel>& cams = sequence.cameras;
  if (cams.empty() || count < 1) return out;
  const glm::dvec3 up = UpAxis(cams), centre = Centre(pose);
  const int n = static_cast<int>(cams.size());
  const int views = std::min(count, n);
  for (int i = 0; i < views; ++i) {
    const int k = i * n / views;
    const scene::CameraModel& a = cams[static_cast<size_t>(k)];
    const scene::CameraModel& b = cams[static_cast<size_t>((k + 1) % n)];
    // Between a and b; a lone camera is turned by 60 degrees.
    double angle = n > 1 ? 0.5 * AngleAbout(up, a.CenterInWorld() - centre, b.CenterInWorld() - centre) : kPi / 3.0;
    if (n == 2 && k == 1) angle += kPi;  // the other side, not the same midpoint again
    // The camera moved by Q about the centre: x_cam = R (Q^T (X - c) + c) + t.
    const glm::dmat3 q = Rotation(up, angle);
    scene::CameraModel v = a;
    v.cam_from_world_rotation = a.cam_from_world_rotation * glm::transpose(q);
    v.cam_from_world_translation =
        a.cam_from_world_translation + a.cam_from_world_rotation * centre - v.cam_from_world_rotation * centre;
    std::fill(v.distortion.begin(), v.distortion.end(), 0.0);
    v.name = n > 1 ? absl::StrCat("between ", a.name, " and ", b.name) : absl::StrCat(a.name, " turned 60 deg");
    out.push_back(v);
  }
  return out;
}

std::vector<scene::Light> HeldOutLights(const scene::Sequence& sequence, const std::vector<scene::Light>& capture_lights,
                                        const std::vector<glm::vec3>& pose, int count) {
  std::set<std::string> used;
  for (const scene::Light& l : capture_lights) used.insert(l.name);
  std::vector<scene::Light> candidates;
  for (const scene::Light& l : sequence.lights) {
    if (!used.count(l.name)) candidates.push_back(l);
  }
  if (candidates.empty()) {
    const glm::dvec3 up = UpAxis(sequence.cameras), centre = Centre(pose);
    const glm::dmat3 q = Rotation(up, kPi / 4.0);
    for (scene::Light l : capture_lights) {
      if (l.directional) {
        l.direction = glm::vec3(glm::normalize(q * glm::dvec3(l.direction)));
      } else {
        l.position = glm::vec3(centre + q * (glm::dvec3(l.position) - centre));
      }
      l.name = absl::StrCat(l.name, " turned 45 deg");
      candidates.push_back(l);
    }
  }
  std::vector<scene::Light> out;
  const int n = static_cast<int>(candidates.size());
  const int lights = std::min(count, n);
  for (int i = 0; i < lights; ++i) out.push_back(candidates[static_cast<size_t>(i * n / lights)]);
  return out;
}

// One material's figures from its sums of squared error and squared truth
// over n pixels (three channels each).
void AddMaterialRow(const v1::GroundTruth& message, const synth::GroundTruth& truth, int m, double sq,
                    double truth_sq, uint64_t n, v1::RelightingMaterialRow* row) {
  row->set_material(message.materials(m).name());
  row->set_truth_brdf(truth.IsMeasured(m) ? absl::StrCat("measured ", message.materials(m).measured())
                                          : std::string(brdf::ModelName(truth.Model())));
  row->set_pixels(n);
  row->set_rmse(std::sqrt(sq / (3.0 * static_cast<double>(n))));
  row->set_relative_rmse(truth_sq > 0.0 ? std::sqrt(sq / truth_sq) : 0.0);
}

absl::StatusOr<v1::RelightingEvaluation> EvaluateRelighting(const std::filesystem::path& run_dir,
                                                            const synth::GroundTruth& truth,
                                                            const scene::Sequence& sequence, gl::EglContext& context,
                                                            const RelightingOptions& options) {
  if (options.views < 1 || options.lights < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("relighting: views and lights must be >= 1, got ", options.views, " and ", options.lights));
  }
  if (options.supersample < 1 || options.supersample > 8) {
    return absl::InvalidArgumentError(
        absl::StrCat("relighting: supersample must be in [1, 8], got ", options.supersample));
  }
  const int frame = options.frame >= 0 ? options.frame : sequence.num_frames / 2;
  if (frame >= sequence.num_frames) {
    return absl::InvalidArgumentError(
        absl::StrCat("relighting: frame ", frame, " of a scene of ", sequence.num_frames, " frames"));
  }
  const v1::GroundTruth& message = truth.message();
  if (message.triangle_materials_size() != static_cast<int>(sequence.topology.triangles.size())) {
    return absl::InvalidArgumentError(absl::StrCat("relighting: the truth has ", message.triangle_materials_size(),
                                                   " triangles, the scene ", sequence.topology.triangles.size()));
  }
  MVBRDF_ASSIGN_OR_RETURN(auto reconstruction, ReconstructionRenderer::Open(run_dir, sequence, context, options.grazing_support));

  // The truth, drawn as the generator drew it (clean mesh: the scene's).
  render::RenderMesh mesh;
  mesh.triangles = sequence.topology.triangles;
  mesh.uvs = sequence.topology.uvs;
  mesh.rest_positions = scene::ToRenderVertices(sequence.topology, sequence.rest_positions);
  mesh.triangle_material.assign(message.triangle_materials().begin(), message.triangle_materials().end());
  render::RendererOptions renderer_options;
  renderer_options.shadow_map_size = message.shadow_map_size() > 0 ? static_cast<int>(message.shadow_map_size()) : 1024;
  renderer_options.inverse_square_falloff = message.inverse_square_falloff();
  renderer_options.brdf_model = truth.Model();
  MVBRDF_ASSIGN_OR_RETURN(auto renderer, render::PhongRenderer::Create(context, mesh, renderer_options));
  MVBRDF_RETURN_IF_ERROR(renderer->SetMeasuredBrdfs(truth.MeasuredBrdfs()));
  MVBRDF_RETURN_IF_ERROR(renderer->SetProceduralMaterials(truth.RendererMaterials()));
  if (!truth.KdTexture().empty()) MVBRDF_RETURN_IF_ERROR(renderer->SetKdTexture(truth.KdTexture()));
  // The truth's surface detail (issue #18), in the scene mesh's UV frames.
  MVBRDF_RETURN_IF_ERROR(renderer->SetNormalDetail(truth.Detail()));
  MVBRDF_ASSIGN_OR_RETURN(const scene::FramePositions positions, sequence.LoadFrame(frame));
  render::Pose pose;
  pose.positions = scene::ToRenderVertices(sequence.topology, positions);
  pose.normals =
      scene::ToRenderVertices(sequence.topology, scene::ComputeFileVertexNormals(sequence.topology, positions));
  // The images are the truth times the exposure gain (as evaluate's kd).
  const double exposure = message.perturbations().exposure();
  const float gain = exposure > 0.0 ? static_cast<float>(exposure) : 1.0f;

  const std::vector<scene::CameraModel> views = HeldOutViews(sequence, pose.positions, options.views);
  // Held out from the whole capture: with per-frame lighting (OLAT) every
  // light that lit some frame counts as seen.
  const std::vector<scene::Light> lights = HeldOutLights(sequence, truth.ActiveLights(), pose.positions, options.lights);
  v1::RelightingEvaluation out;
  out.set_frame(static_cast<uint32_t>(frame));
  out.set_supersample(static_cast<uint32_t>(options.supersample));
  out.set_grazing_support(reconstruction->holds_grazing_support());
  const int num_materials = message.materials_size();
  std::vector<double> material_sq(static_cast<size_t>(num_materials), 0.0),
      material_truth_sq(static_cast<size_t>(num_materials), 0.0);
  std::vector<uint64_t> material_n(static_cast<size_t>(num_materials), 0);
  double all_sq = 0.0, all_truth_sq = 0.0;
  uint64_t all_n = 0, unobserved = 0;
  const int ss = options.supersample;
  for (const scene::CameraModel& view : views) {
    // Drawn at ss x ss subpixels per pixel and box-averaged: a pixel records
    // the radiance over its area, as a sensor does (a lobe narrower than a
    // pixel's footprint is otherwise judged by where one ray happens to land).
    const scene::CameraModel fine = scene::Supersampled(view, ss);
    MVBRDF_ASSIGN_OR_RETURN(const cv::Mat ids, renderer->RenderTriangleIds(pose, fine, 1));
    cv::Mat observed;  // depends on the view only: found with its first light
    for (const scene::Light& light : lights) {
      MVBRDF_RETURN_IF_ERROR(renderer->SetLights({light}));
      MVBRDF_ASSIGN_OR_RETURN(const render::RenderOutput t, renderer->Render(pose, fine));
      cv::Mat coverage;
      ReconstructionRenderer::Extras extras;
      extras.coverage = &coverage;
      if (observed.empty()) extras.observed = &observed;
      MVBRDF_ASSIGN_OR_RETURN(const cv::Mat r_fine, reconstruction->Render(fine, {light}, frame, false, extras));
      cv::Mat r, t_radiance;
      cv::resize(r_fine, r, cv::Size(view.width, view.height), 0, 0, cv::INTER_AREA);
      cv::resize(t.radiance, t_radiance, cv::Size(view.width, view.height), 0, 0, cv::INTER_AREA);
      double sq = 0.0, truth_sq = 0.0;
      uint64_t n = 0;
      std::vector<double> row_sq(static_cast<size_t>(num_materials), 0.0),
          row_truth_sq(static_cast<size_t>(num_materials), 0.0);
      std::vector<uint64_t> row_n(static_cast<size_t>(num_materials), 0);
      cv::Mat counted;
      if (options.on_row) counted = cv::Mat::zeros(r.rows, r.cols, CV_8UC1);
      for (int y = 0; y < r.rows; ++y) {
        for (int x = 0; x < r.cols; ++x) {
          // A pixel counts when every subpixel shows the mesh in both images
          // and a texel the run observed.
          bool covered = true, seen = true;
          for (int j = y * ss; j < (y + 1) * ss && covered; ++j) {
            for (int i = x * ss; i < (x + 1) * ss && covered; ++i) {
              covered = ids.at<int32_t>(j, i) >= 0 && t.coverage.at<uint8_t>(j, i) != 0 &&
                        coverage.at<float>(j, i) >= 0.999f;
              seen = seen && observed.at<uint8_t>(j, i) != 0;
            }
          }
          if (!covered) continue;
          if (!seen) {
            ++unobserved;
            continue;
          }
          const int id = ids.at<int32_t>(y * ss + ss / 2, x * ss + ss / 2);  // the material: the centre subpixel's
          if (!counted.empty()) counted.at<uint8_t>(y, x) = 255;
          const cv::Vec3f& a = r.at<cv::Vec3f>(y, x);
          const cv::Vec3f b = gain * t_radiance.at<cv::Vec3f>(y, x);
          double e = 0.0, m = 0.0;
          for (int c = 0; c < 3; ++c) {
            e += (a[c] - b[c]) * (a[c] - b[c]);
            m += b[c] * b[c];
          }
          const size_t material = message.triangle_materials(id);
          row_sq[material] += e;
          row_truth_sq[material] += m;
          ++row_n[material];
          sq += e;
          truth_sq += m;
          ++n;
        }
      }
      v1::RelightingRow* row = out.add_rows();
      row->set_view(view.name);
      row->set_light(light.name);
      row->set_pixels(n);
      row->set_rmse(n > 0 ? std::sqrt(sq / (3.0 * n)) : 0.0);
      row->set_truth_rms(n > 0 ? std::sqrt(truth_sq / (3.0 * n)) : 0.0);
      for (int m = 0; m < num_materials; ++m) {
        const size_t i = static_cast<size_t>(m);
        material_sq[i] += row_sq[i];
        material_truth_sq[i] += row_truth_sq[i];
        material_n[i] += row_n[i];
        if (row_n[i] > 0) AddMaterialRow(message, truth, m, row_sq[i], row_truth_sq[i], row_n[i], row->add_materials());
      }
      all_sq += sq;
      all_truth_sq += truth_sq;
      all_n += n;
      if (options.on_row) {
        const cv::Mat truth_image = gain * t_radiance;
        RelightingRowImages images;
        images.row = out.rows_size() - 1;
        images.frame = frame;
        images.view = &view;
        images.light = &light;
        images.truth = &truth_image;
        images.reconstruction = &r;
        images.counted = &counted;
        MVBRDF_RETURN_IF_ERROR(options.on_row(images));
      }
    }
  }
  if (all_n == 0) {
    return absl::FailedPreconditionError(
        "relighting: no pixel of the held-out views shows a texel the run observed (nothing to compare)");
  }
  out.set_rmse(std::sqrt(all_sq / (3.0 * all_n)));
  out.set_relative_rmse(all_truth_sq > 0.0 ? std::sqrt(all_sq / all_truth_sq) : 0.0);
  out.set_unobserved_pixels(unobserved);
  for (int m = 0; m < num_materials; ++m) {
    const size_t i = static_cast<size_t>(m);
    if (material_n[i] > 0) {
      AddMaterialRow(message, truth, m, material_sq[i], material_truth_sq[i], material_n[i], out.add_materials());
    }
  }
  return out;
}

}  // namespace mvbrdf::pipeline
