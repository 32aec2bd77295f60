// `mvbrdf evaluate`'s relighting error (issue #15): a reconstruction and the
// generator's truth drawn by the same renderer from views and under lights
// the capture did not have, compared pixel by pixel in linear radiance. When
// the truth is no analytic model (synth --materials) there are no parameters
// to compare: this is the figure a model is judged by.
//
// Held-out views: for up to `views` pairs of consecutive capture cameras, a
// camera turned from the first towards the second by half their angle about
// the scene's up axis (the cameras' mean up) through the subject's centre,
// with the first's intrinsics and no lens distortion. Held-out lights: the
// scene's candidate lights no frame of the truth's capture used (each alone),
// else (an OLAT capture used them all) the capture's lights turned by 45
// degrees about the up axis. The pose: one
// frame (the middle one by default). Pixels count where both images cover the
// mesh and the surface point's texel was observed by the run (with
// `supersample` > 1: at every subpixel of the pixel).
#ifndef MVBRDF_CORE_PIPELINE_RELIGHTING_EVALUATION_H_
#define MVBRDF_CORE_PIPELINE_RELIGHTING_EVALUATION_H_

#include <filesystem>
#include <functional>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "core/gl/egl_context.h"
#include "core/scene/camera_model.h"
#include "core/scene/light.h"
#include "core/scene/sequence.h"
#include "core/synth/ground_truth.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::pipeline {

// One row's images, for a caller that keeps them (`evaluate --relight-images`):
// the view and light drawn, the truth (times the exposure gain) and the
// reconstruction (CV_32FC3, linear), and the pixels the row's RMSE counts
// (CV_8UC1, 255 where counted).
struct RelightingRowImages {
  int row = 0;  // RelightingEvaluation.rows' index
  int frame = 0;
  const scene::CameraModel* view = nullptr;
  const scene::Light* light = nullptr;
  const cv::Mat* truth = nullptr;
  const cv::Mat* reconstruction = nullptr;
  const cv::Mat* counted = nullptr;
};

struct RelightingOptions {
  int views = 4;    // held-out views, >= 1
  int lights = 3;   // held-out lights, >= 1, each drawn alone
  int frame = -1;   // the pose drawn, relative to the scene's first frame; -1: the middle one
  // Subpixels per pixel side, in [1, 8]: both images are drawn at this many
  // times the view's resolution and box-averaged, as a sensor integrates a
  // pixel's area, and a pixel counts when all its subpixels would. 1 (the
  // default) samples each pixel's centre, as synth draws the capture's frames.
  int supersample = 1;
  // The reconstruction's GGX clusters drawn within their grazing supports
  // (as mvbrdf draws them; ReconstructionRenderer::Open); false: the plain
  // glTF lobes.
  bool grazing_support = true;
  // Called once per row after it is scored; an error stops the evaluation.
  std::function<absl::Status(const RelightingRowImages&)> on_row;
};

// The held-out views and lights for a sequence whose capture used
// `capture_lights` (by name), as described above. Exposed for tests.
std::vector<scene::CameraModel> HeldOutViews(const scene::Sequence& sequence, const std::vector<glm::vec3>& pose,
                                             int count);
std::vector<scene::Light> HeldOutLights(const scene::Sequence& sequence, const std::vector<scene::Light>& capture_lights,
                                        const std::vector<glm::vec3>& pose, int count);

// `run_dir` an output of `mvbrdf run` of `sequence` (its scene), `truth` the
// synthetic bundle's truth. The context must be current on this thread.
absl::StatusOr<v1::RelightingEvaluation> EvaluateRelighting(const std::filesystem::path& run_dir,
                                                            const synth::GroundTruth& truth,
                                                            const scene::Sequence& sequence, gl::EglContext& context,
                                                            const RelightingOptions& options = {});

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_RELIGHTING_EVALUATION_H_
