// A reconstruction (the output directory of `mvbrdf run`) drawn from any
// camera under any lights, in the pose of any frame, optionally with that
// frame's correction atlas (shared/NOTES.md: render with kd + c). Used by
// `mvbrdf render` and by the report (input beside reconstruction, relit
// sequences).
#ifndef MVBRDF_CORE_PIPELINE_RECONSTRUCTION_RENDERER_H_
#define MVBRDF_CORE_PIPELINE_RECONSTRUCTION_RENDERER_H_

#include <filesystem>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "core/atlas/atlas.h"
#include "core/gl/egl_context.h"
#include "core/render/phong_renderer.h"
#include "core/scene/sequence.h"

namespace mvbrdf::pipeline {

class ReconstructionRenderer {
 public:
  // `sequence` (the run's scene) must outlive the renderer. The layout is
  // rebuilt (deterministically) from the scene and checked against the
  // run's atlas/triangle_id.exr (FAILED_PRECONDITION when they differ).
  // `grazing_support`: each GGX cluster drawn within its grazing support
  // (result.json clusters[].ggxGrazingSupport, brdf::Ggx::SpecularWithin),
  // as mvbrdf draws a reconstruction; false: the plain lobe, extrapolated as
  // a glTF viewer draws the export.
  static absl::StatusOr<std::unique_ptr<ReconstructionRenderer>> Open(const std::filesystem::path& run_dir,
                                                                      const scene::Sequence& sequence,
                                                                      gl::EglContext& context,
                                                                      bool grazing_support = true);

  // Linear radiance (CV_32FC3) with the camera's lens distortion applied.
  absl::StatusOr<cv::Mat> Render(const scene::CameraModel& camera, const std::vector<scene::Light>& lights,
                                 int frame, bool correction);

  struct Extras {
    // A constant ambient term (linear RGB, the lights' units): every covered
    // pixel gets kd * ambient added, kd the reconstruction's (with the
    // frame's correction when asked) at the pixel's surface point.
    glm::vec3 ambient{0.0f};
    // When set: the mesh's coverage of each pixel, CV_32FC1 in [0, 1] (1
    // where it covers the pixel centre, 0 where it does not; fractional only
    // where lens distortion resamples an edge).
    cv::Mat* coverage = nullptr;
    // When set: CV_8UC1, 255 where the pixel's surface point lies in a texel
    // the run observed (atlases/confidence.exr > 0), else 0; the undistorted
    // image (as Render's own pixels before the lens), for held-out views.
    cv::Mat* observed = nullptr;
  };
  absl::StatusOr<cv::Mat> Render(const scene::CameraModel& camera, const std::vector<scene::Light>& lights,
                                 int frame, bool correction, const Extras& extras);

  // Whether GGX clusters are drawn within their grazing supports (false:
  // not asked, or no cluster has one).
  bool holds_grazing_support() const { return !ggx_support_.empty(); }

 private:
  ReconstructionRenderer(const std::filesystem::path& run_dir, const scene::Sequence& sequence, atlas::Atlas atlas)
      : run_dir_(run_dir), sequence_(sequence), atlas_(std::move(atlas)) {}

  const std::filesystem::path run_dir_;
  const scene::Sequence& sequence_;
  const atlas::Atlas atlas_;
  cv::Mat kd_, ks_, ke_;
  cv::Mat p3_;  // GGX's f90_ratio atlas (empty: none, a dielectric's 25)
  cv::Mat confidence_;
  cv::Mat model_;  // --brdf auto: the per-texel model (CV_8UC1), else empty
  cv::Mat corrected_kd_;  // kd + the last correction atlas rendered
  render::RenderMesh mesh_;
  cv::Mat ggx_support_;  // GgxSupportAtlas (empty: the plain lobes)
  bool with_correction_ = false;  // the renderer's kd currently includes a correction atlas
  std::unique_ptr<render::PhongRenderer> renderer_;
};

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_RECONSTRUCTION_RENDERER_H_
