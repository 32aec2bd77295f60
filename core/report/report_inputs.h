// Gathers what the HTML report shows from a run's output directory: its
// result.json, the atlas previews, an evaluation against the ground truth
// (when the scene's bundle has ground_truth/, or one is given), the
// error-against-run-time points of scripts/bench-tradeoff, and — with a GL
// context — input frames beside renderings of the reconstruction and a relit
// sequence with a point light moving around the model on the camera's side.
#ifndef MVBRDF_CORE_REPORT_REPORT_INPUTS_H_
#define MVBRDF_CORE_REPORT_REPORT_INPUTS_H_

#include <filesystem>
#include <vector>

#include <glm/glm.hpp>

#include "absl/status/statusor.h"
#include "core/gl/egl_context.h"
#include "core/report/report_page.h"
#include "core/scene/camera_model.h"

namespace mvbrdf::report {

struct ReportOptions {
  // Ground truth: a bundle directory with ground_truth/ (empty: the scene's
  // own directory when it has one).
  std::filesystem::path truth;
  bool use_truth = true;
  // The run's scene file (empty: result.json's, pipeline::SceneOfRun).
  std::filesystem::path scene;
  // A TradeoffReport JSON (scripts/bench-tradeoff); empty: none.
  std::filesystem::path tradeoff;
  // Renderings (input beside reconstruction, the relit sequence) need a
  // context; null: the report has none.
  gl::EglContext* gl = nullptr;
  int max_cameras = 4;    // cameras shown beside their input
  int relit_frames = 12;  // positions of the circling light
  std::filesystem::path scratch_dir;  // temporary files (removed by the caller)
};

// The relit sequence's point light (thesis Fig. 7.7): `frames` positions
// swinging from 80 degrees left of `camera` to 80 degrees right of it around
// the model's centre (the box lo..hi), 25 degrees above it towards the
// camera's up, at 1.5 times the box's diagonal; always on the camera's side
// of the model, so that no frame shows only its unlit back.
struct RelitLight {
  glm::vec3 position;
  int degrees = 0;  // from the camera's direction, + to the camera's right
};
std::vector<RelitLight> RelitLightPath(const scene::CameraModel& camera, const glm::vec3& lo, const glm::vec3& hi,
                                       int frames);

absl::StatusOr<ReportInputs> CollectReportInputs(const std::filesystem::path& run_dir, const ReportOptions& options);

}  // namespace mvbrdf::report

#endif  // MVBRDF_CORE_REPORT_REPORT_INPUTS_H_
