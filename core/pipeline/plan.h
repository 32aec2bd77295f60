// The plan of a reconstruction job: only the stages the scene and the
// requested outputs need, each with why it runs, and every stage left out
// with the reason (reported in result.json and printed).
#ifndef MVBRDF_CORE_PIPELINE_PLAN_H_
#define MVBRDF_CORE_PIPELINE_PLAN_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/job_options.pb.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::pipeline {

// What the user asked for.
struct RunRequest {
  bool light_table = true;      // Table 6.1: the sweep over candidate configurations
  bool brdf_atlases = true;     // kd, ks, ke, cluster and confidence atlases
  bool correction = true;       // per-frame correction atlases
  bool camera_errors = true;    // Table 7.1
  bool compare_solvers = true;  // Table 6.2: Powell beside Levenberg-Marquardt
  // Issue #18: per-texel normals refined from the video (off unless asked:
  // extra passes over every frame, see core/pipeline/normal_stage.h).
  bool normals = false;
  // A known configuration (by name): the sweep is not needed.
  std::string configuration;
  // The configurations to sweep (names of the scene's), in this order; empty:
  // every configuration of the scene. One is the same as `configuration`.
  std::vector<std::string> candidates;
  // Issue #14: the refinement stages (v1::FittingOptions.refine_*).
  v1::Refinement refine_cameras = v1::REFINEMENT_AUTO;
  v1::Refinement refine_lights = v1::REFINEMENT_AUTO;
  // For the cluster_fit stage's line: the model fitted ("phong", "ggx",
  // "auto", ...) and ReconstructOptions::pixel_footprint.
  std::string brdf = "phong";
  int pixel_footprint = 1;
};

enum class Stage {
  kAtlas,            // build a texture atlas (meshes without UVs)
  kRefineCameras,    // camera poses (and focal, k1) refined from the video (core/calibrate)
  kGatherSamples,    // pass 1: resample, triangle Samples, per-texel statistics
  kLightSweep,       // fit every candidate configuration, choose one
  kRefineLights,     // the chosen configuration's lights refined continuously
  kClustering,       // k-means of texels into materials
  kClusterFit,       // one Phong BRDF per cluster (LM)
  kSolverComparison, // the same fits with Powell's method
  kNormals,          // per-texel normals refined from the video (issue #18), before pass 2
  kTexelPass,        // pass 2: resample again, per-texel kd, camera errors
  kCorrection,       // per-frame correction atlases
  kCameraErrors,     // Table 7.1
  kWriteAtlases,     // kd, ks, ke, cluster, confidence atlases
};

const char* StageName(Stage stage);

struct Plan {
  struct Step {
    Stage stage;
    std::string why;
  };
  std::vector<Step> steps;  // in order
  std::vector<v1::SkippedStage> skipped;
  // The configuration used when the sweep is skipped (or empty when it runs).
  std::string fixed_configuration;
  // The configurations the sweep fits, in order, when it runs (the request's
  // candidates, else the scene's).
  std::vector<std::string> candidates;

  bool Has(Stage stage) const;
  void ToProto(v1::Plan* plan) const;
  // One line per stage for people.
  std::string Describe() const;
};

// INVALID_ARGUMENT when the request names an unknown configuration (given or
// as a candidate; "--config" and "--candidates" name the flags in the
// message), an empty or repeated candidate, both, or asks for nothing.
absl::StatusOr<Plan> MakePlan(const scene::Sequence& sequence, const RunRequest& request);

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_PLAN_H_
