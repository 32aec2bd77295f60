#include "core/pipeline/reconstruction_renderer.h"

#include <cstdio>

#include "absl/strings/str_cat.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/image/exr.h"
#include "core/synth/frame_encoder.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::pipeline {
namespace {

absl::StatusOr<cv::Mat> ReadRgb(const std::filesystem::path& file) {
  MVBRDF_ASSIGN_OR_RETURN(image::ExrImage exr, image::ReadExr(file));
  if (exr.image.type() != CV_32FC3) return absl::InvalidArgumentError(absl::StrCat(file.string(), ": expected RGB"));
  return exr.image;
}

}  // namespace

absl::StatusOr<std::unique_ptr<ReconstructionRenderer>> ReconstructionRenderer::Open(
    const std::filesystem::path& run_dir, const scene::Sequence& sequence, gl::EglContext& context) {
  MVBRDF_ASSIGN_OR_RETURN(const v1::RunReport run, ReadJsonFileAs<v1::RunReport>(run_dir / "result.json"));
  atlas::AtlasOptions atlas_options;
  atlas_options.size = static_cast<int>(run.atlas().size());
  MVBRDF_ASSIGN_OR_RETURN(atlas::Atlas atlas,
                          atlas::BuildAtlas(sequence.topology, sequence.rest_positions, atlas_options));
  MVBRDF_ASSIGN_OR_RETURN(const image::ExrImage ids, image::ReadExr(run_dir / "atlas" / "triangle_id.exr"));
  if (ids.image.size() != atlas.triangle_id.size() || cv::norm(ids.image, atlas.triangle_id, cv::NORM_INF) != 0) {
    return absl::FailedPreconditionError(
        absl::StrCat(run_dir.string(), "/atlas/triangle_id.exr: the run's atlas differs from the one built now"));
  }
  auto r = std::unique_ptr<ReconstructionRenderer>(new ReconstructionRenderer(run_dir, sequence, std::move(atlas)));
  MVBRDF_ASSIGN_OR_RETURN(r->kd_, ReadRgb(run_dir / "atlases" / "kd.exr"));
  MVBRDF_ASSIGN_OR_RETURN(r->ks_, ReadRgb(run_dir / "atlases" / "ks.exr"));
  MVBRDF_ASSIGN_OR_RETURN(r->ke_, ReadRgb(run_dir / "atlases" / "ke.exr"));
  render::RenderMesh mesh;
  mesh.triangles = r->atlas_.topology.triangles;
  mesh.uvs = r->atlas_.topology.uvs;
  mesh.rest_positions = scene::ToRenderVertices(r->atlas_.topology, sequence.rest_positions);
  MVBRDF_ASSIGN_OR_RETURN(r->renderer_, render::PhongRenderer::Create(context, mesh, {}));
  MVBRDF_RETURN_IF_ERROR(r->renderer_->SetAtlasMaterials(r->kd_, r->ks_, r->ke_));
  return r;
}

absl::StatusOr<cv::Mat> ReconstructionRenderer::Render(const scene::CameraModel& camera,
                                                       const std::vector<scene::Light>& lights, int frame,
                                                       bool correction) {
  if (frame < 0 || frame >= sequence_.num_frames) {
    return absl::InvalidArgumentError(absl::StrCat("frame: must be in [0, ", sequence_.num_frames, "), got ", frame));
  }
  if (correction) {
    char name[32];
    std::snprintf(name, sizeof(name), "%04d.exr", sequence_.AbsoluteFrame(frame));
    MVBRDF_ASSIGN_OR_RETURN(const cv::Mat c, ReadRgb(run_dir_ / "atlases" / "correction" / name));
    MVBRDF_RETURN_IF_ERROR(renderer_->SetAtlasMaterials(kd_ + c, ks_, ke_));  // render with kd + c
    with_correction_ = true;
  } else if (with_correction_) {
    MVBRDF_RETURN_IF_ERROR(renderer_->SetAtlasMaterials(kd_, ks_, ke_));
    with_correction_ = false;
  }
  MVBRDF_RETURN_IF_ERROR(renderer_->SetLights(lights));
  MVBRDF_ASSIGN_OR_RETURN(const scene::FramePositions positions, sequence_.LoadFrame(frame));
  render::Pose pose;
  pose.positions = scene::ToRenderVertices(atlas_.topology, positions);
  pose.normals = scene::ToRenderVertices(atlas_.topology, scene::ComputeFileVertexNormals(atlas_.topology, positions));
  MVBRDF_ASSIGN_OR_RETURN(const render::RenderOutput image, renderer_->Render(pose, camera));
  return synth::ApplyDistortion(image.radiance, camera);
}

}  // namespace mvbrdf::pipeline
