// Measures resampled atlases against the generator's ground truth: the true
// radiance at each texel's surface point (rendered by the same renderer that
// made the videos, in atlas space, with the true cameras, lights and
// materials) and the true visibility of each texel (no surface crosses the
// camera ray in front of the texel's point: the generator's triangle id
// buffer at 4x the camera's resolution names the front surfaces, an exact
// ray-triangle test decides).
#ifndef MVBRDF_CORE_EVALUATE_RESAMPLE_EVALUATOR_H_
#define MVBRDF_CORE_EVALUATE_RESAMPLE_EVALUATOR_H_

#include <map>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "core/atlas/atlas.h"
#include "core/gl/egl_context.h"
#include "core/render/phong_renderer.h"
#include "core/resample/resampler.h"
#include "core/scene/sequence.h"
#include "core/synth/ground_truth.h"
#include "mvbrdf/v1/resample_report.pb.h"

namespace mvbrdf::evaluate {

// Sums over texels, kept per camera and added up over frames.
struct ResampleTally {
  uint64_t covered = 0;
  uint64_t valid = 0;
  uint64_t truly_visible = 0;
  uint64_t valid_and_visible = 0;
  double sum_sq_valid = 0.0;          // squared radiance error, summed over RGB, over valid texels
  double sum_abs_valid = 0.0;
  double sum_sq_valid_and_visible = 0.0;

  void Add(const ResampleTally& other);
  // Fills the counts and error figures of `figures` (not its name).
  void ToFigures(bool with_truth, v1::CameraFigures* figures) const;
};

// Counts covered and valid texels of one resampled atlas (no truth needed).
ResampleTally CountValid(const cv::Mat& resampled, const atlas::Atlas& atlas);

class ResampleEvaluator {
 public:
  // Shares the caller's context. `rest_positions` is the scene mesh's frame 0
  // (the solid textures' coordinates). The grazing margin must be the
  // resampler's, so that "truly visible" means the same geometric test. The
  // atlas must outlive the evaluator.
  static absl::StatusOr<std::unique_ptr<ResampleEvaluator>> Create(gl::EglContext& context,
                                                                   const synth::GroundTruth& truth,
                                                                   const atlas::Atlas& atlas,
                                                                   const scene::FramePositions& rest_positions,
                                                                   const resample::ResamplerOptions& options);

  // The pose of the next frame (file-vertex positions of the scene's mesh)
  // and, where the truth lit frames by their own lights, absolute frame
  // `frame`'s lights (synth::GroundTruth::FrameLights).
  absl::Status SetFrame(const scene::FramePositions& file_positions, uint32_t frame = 0);

  // Compares camera `camera`'s resampled atlas (CV_32FC4) of the current
  // frame, with the frame's geometry atlas, against the truth.
  absl::StatusOr<ResampleTally> Evaluate(int camera, const cv::Mat& resampled,
                                         const resample::GeometryAtlas& geometry);

  // Supersampling of the id buffer used for visibility.
  static constexpr int kIdSupersample = 4;
  // A surface in front of a texel's point by more than this fraction of the
  // point's distance hides it (0.3 mm at 3 m: parts that interpenetrate by
  // more than that are hidden, as they are in the generator's images).
  static constexpr double kOcclusionRelativeEpsilon = 1e-4;

 private:
  ResampleEvaluator() = default;
  // Distance along the unit ray to the current pose's triangle, or +inf.
  double RayTriangle(const glm::dvec3& origin, const glm::dvec3& dir, uint32_t triangle) const;
  const atlas::Atlas* atlas_ = nullptr;
  std::vector<scene::CameraModel> true_cameras_;
  resample::ResamplerOptions options_;
  std::unique_ptr<render::PhongRenderer> renderer_;
  render::Pose pose_;
  // Absolute frame -> its lights, where the truth lit frames by their own.
  std::map<uint32_t, std::vector<scene::Light>> frame_lights_;
  std::vector<scene::Light> all_lights_;
};

}  // namespace mvbrdf::evaluate

#endif  // MVBRDF_CORE_EVALUATE_RESAMPLE_EVALUATOR_H_
