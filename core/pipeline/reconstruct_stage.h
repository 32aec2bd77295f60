// `mvbrdf run`: the thesis's whole pipeline on one sequence (chapters 5-7),
// planned from the scene and the requested outputs (core/pipeline/plan.h).
//
//   pass 1  resample every frame; triangle Samples (averaged atlases) for the
//           light sweep; per-texel mean reflectance and a few kept Samples
//   sweep   one Phong BRDF + per-triangle kd per candidate configuration
//   cluster k-means of texel means; one Phong BRDF per cluster (LM, Powell)
//   pass 2  resample again; per-texel kd with the cluster's specular part
//           removed (closed form, streamed); per-frame observed diffuse
//           albedo for the correction atlases; per-camera errors (Table 7.1)
//
// Resampling twice keeps memory independent of the number of frames.
//
// Output layout under out_dir:
//   result.json                     RunReport
//   atlas/mesh.obj                  rest pose with the atlas UVs (render with these): v = the input's
//                                   vertices in its order, vt = atlas vertices (scene::WriteAtlasMesh)
//   atlas/seams.txt                 per atlas vertex its input vertex
//   atlas/triangle_id.exr, rest_position.exr
//   atlases/kd.exr ks.exr ke.exr    grown for rendering (RGB), PNG previews
//   atlases/cluster.exr (+ .png)    cluster per texel, -1 where never seen
//   atlases/confidence.exr          observations per texel (0 = never seen)
//   atlases/correction/NNNN.exr     per frame: c = kd_o - kd (shared/NOTES.md), render kd + c
#ifndef MVBRDF_CORE_PIPELINE_RECONSTRUCT_STAGE_H_
#define MVBRDF_CORE_PIPELINE_RECONSTRUCT_STAGE_H_

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "core/brdf/model.h"
#include "core/atlas/atlas.h"
#include "core/fit/texel_normal_fit.h"
#include "core/fit/diffuse.h"
#include "core/fit/phong_fit.h"
#include "core/gl/egl_context.h"
#include "core/pipeline/plan.h"
#include "core/pipeline/texel_statistics.h"
#include "core/resample/resampler.h"
#include "core/samples/assemble.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/job_options.pb.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::pipeline {

struct ReconstructOptions {
  RunRequest request;
  atlas::AtlasOptions atlas;
  resample::ResamplerOptions resampler;
  samples::AssembleOptions assemble;
  // Gather the half-vector geometry into every Sample (triangle Samples and
  // the kept texel Samples; SampleSet::half_vector), which the models other
  // than the thesis's Phong read (issue #15). Off on the Phong path: its
  // Samples are what they were. (A brdf_model other than Phong gathers it
  // into the kept texel Samples only: the sweep's triangle Samples, and the
  // service's cache of them, stay the Phong path's.)
  bool half_vector_geometry = false;
  // The reflectance model fitted per cluster (issue #15; --brdf): the
  // thesis's Phong by default. Another model gathers the half-vector
  // geometry whatever half_vector_geometry says, fits each cluster with
  // fit::FitLobe after the Phong fit (kept for Table 6.2 and the flags), and
  // writes its parameters' atlases (brdf::ParameterNames: ks, ke or f0,
  // roughness). The light sweep stays the thesis's Phong (a choice among
  // configurations, which the lobe's shape barely moves).
  brdf::Model brdf_model = brdf::Model::kPhong;
  // `--brdf auto`: brdf_model unused; each cluster fits the model of
  // core/brdf that fit::SelectModel picks from its Samples (lowest error on
  // held-out frames and a held-out camera), and the atlases are model-neutral:
  // atlases/model.png (brdf::Model's value per texel, 255 where none) and
  // parameter_1, parameter_2 (each texel's model's parameters, in
  // brdf::ParameterNames' order).
  bool brdf_auto = false;
  bool GathersHalfVector() const {
    return half_vector_geometry || brdf_auto || brdf::NeedsHalfVector(brdf_model);
  }
  // Triangle averaging for light estimation (thesis §5.1.3).
  float min_valid_fraction = 0.75f;
  fit::PhongFitOptions fit;
  fit::DiffuseOptions diffuse;
  // Per-texel kd shrinks towards its cluster's kd with this many
  // pseudo-observations at the data's typical illumination (mean G^2 of an
  // observation; fit::DiffuseOptions::prior_weight), so independent of the
  // intensity units; keeps texels that saw only grazing or mislabelled light
  // from running away. 0: the thesis's plain least squares. Measured kd RMSE
  // on the 3-camera 6-frame synth sequence (tests/cli_units_test.sh):
  // 0 -> 0.096, 0.1 -> 0.0216, 0.3 -> 0.0196, 1 -> 0.0187 (the former
  // absolute 0.1 at G = 1 gave 0.0187 there: G^2 ~ 0.1 on it).
  double kd_prior_weight = 1.0;
  // Issue #18: the normals stage's solver (it runs when the request asks).
  fit::TexelNormalOptions normals;
  int grow_iterations = 2;
  // Samples kept per texel for the cluster fits (TexelReservoir).
  int reservoir_uniform = 2;
  int reservoir_highlight = 2;
  // The cluster fits' per-pixel Samples model each pixel as the mean over
  // pixel_footprint x pixel_footprint subpixels of its area (what a sensor
  // records; samples::ForEachPixelSample); 1: the pixel centre, the thesis's
  // point sample. In [1, samples::kMaxPixelFootprint].
  int pixel_footprint = 1;
  // Samples per cluster fit, at most (error against run time: more costs
  // fitting time, fewer loses precision on ks and ke).
  size_t max_cluster_samples = 100000;
  // Use every n-th frame for light estimation (1 = all). 0: automatic —
  // every frame up to kMaxSweepFrames frames, else the smallest stride that
  // keeps at most that many (the triangle Samples of all 400 frames of a
  // thesis-scale sequence would take ~3.5 GB; eight configurations are told
  // apart by far fewer). See SweepFrameStride.
  int sweep_frame_stride = 0;
  // The sweep's average BRDF is fitted on at most this many triangle
  // Samples (E_a and E_d still use all of them); 0 = all.
  size_t sweep_fit_samples = 100000;
  // Issue #14 (robustness), from v1::FittingOptions (core/pipeline/job_options.cc).
  // Camera refinement before pass 1 (core/calibrate): auto runs it when
  // cross-camera consistency says the calibration is off.
  v1::Refinement refine_cameras = v1::REFINEMENT_AUTO;
  bool refine_focal = false;
  bool refine_distortion = false;
  bool refine_photometric = false;  // the photometric term in the camera solve (CameraRefinementOptions)
  int refine_frames = 8;
  // The chosen configuration's lights refined after the sweep: auto when a
  // sweep chose the configuration.
  v1::Refinement refine_lights = v1::REFINEMENT_AUTO;
  // Robust loss (scale estimated from the data) in the sweep and per-texel
  // kd; false: least squares. The cluster fits are least squares either way
  // (measured: reconstruct_stage.cc).
  bool robust = true;
  // Observations this close (pixels) to a silhouette or depth discontinuity
  // are rejected; 0: none.
  double edge_margin_pixels = 0.0;
  // Observations on steep image gradients are rejected; 0: none.
  double gradient_rejection = 0.0;
  v1::SweepCriterion sweep_criterion = v1::SWEEP_CRITERION_HELD_OUT;
  // Spatial coherence of the clusters over the surface (cluster::SmoothLabels:
  // the price of one unlike neighbour in typical data costs); 0: off.
  // Measured against the truth (cluster accuracy; 0 -> 16 -> 32 -> 64): samba
  // 8 x 175 0.963 -> 0.978 -> 0.980 -> 0.988 (worst ke error 0.24 -> 0.14 ->
  // 0.105 -> 0.053), actor 8 x 30 clean 0.990 -> 0.9945 -> 0.9946 -> 0.9959,
  // cameras 0.3 deg / 5 mm off 0.934 -> 0.947 (16); a small misregistered
  // actor (cli_cluster_smoothness) 0.843 -> 0.910 -> 0.911 -> 0.906.
  double cluster_smoothness = 64.0;
  int threads = 2;
  // The light sweep's outcome when it ran elsewhere (the service's `choose`
  // task): its light_configurations, chosen_configuration, margin, warning
  // and stages go into the report; no triangle Samples are gathered and no
  // sweep runs. The plan is still made from `request` (it says the sweep ran).
  std::optional<v1::RunReport> light_table;
  // The camera refinement when it ran elsewhere (the service's gather task,
  // GatherResult.calibration): applied to the sequence instead of running
  // calibrate::RefineCameras again (core/pipeline/calibration_stage.h).
  std::optional<v1::CalibrationReport> calibration;
  // Pass 1's texel statistics when they were gathered already with the same
  // options (the service's gather task on this worker); consumed. Without
  // them pass 1 gathers them itself.
  std::shared_ptr<TexelStatistics> texel_statistics;
  // Set by RunReconstruction when it continues with the lights of
  // light_table->calibration() already in its sequence (refine_lights_stage.h).
  bool refined_lights_applied = false;
  std::filesystem::path out_dir;
  // Recorded in result.json (issue #20): every option as asked and resolved
  // (RunReport.options), and where its scene is. A service run names the
  // scene by its path inside the uploaded bundle `bundle_sha256`; otherwise
  // RunReport.scene is the scene file relative to out_dir.
  v1::RunOptions run_options;
  std::string bundle_sha256;
  std::string scene_in_bundle;
  // Called on the calling thread as the job advances: the stage's name (as in
  // result.json's stages), units done and the total (frames for the passes;
  // 1 of 1 for the other stages when they finish). May be empty.
  std::function<void(const std::string& stage, int done, int total)> progress;
  // Called on the calling thread with each stage's row as result.json's
  // stages get it (its name and seconds), once per stage. May be empty.
  std::function<void(const v1::StageRow& stage)> stage_done;
  // Asked once per frame of each pass; true stops the run with CANCELLED
  // (a worker whose lease was lost or whose job was cancelled). May be empty.
  std::function<bool()> cancelled;
};

constexpr int kMaxSweepFrames = 64;

// The head of a run's report: scene, frames, GL renderer, the rule that
// chooses the configuration, and the plan of options.request (with the
// sweep's frames noted). RunReconstruction and the service's choose task
// start from it.
absl::StatusOr<v1::RunReport> NewRunReport(const scene::Sequence& sequence, const ReconstructOptions& options,
                                           const std::string& gl_renderer);

// FAILED_PRECONDITION naming the metric and its row (configuration, cluster
// and solver, or camera) when any figure of the report is NaN or infinite:
// a result that says "Infinity" is no result. The likely cause is input
// values far out of range (e.g. light intensities), which scene validation
// bounds; this is the backstop for what it cannot foresee.
absl::Status CheckMetricsFinite(const v1::RunReport& report);

// The stride the light sweep uses on a sequence of `num_frames` frames.
int SweepFrameStride(const ReconstructOptions& options, int num_frames);

// CANCELLED when options.cancelled says so.
absl::Status CheckCancelled(const ReconstructOptions& options);

// The fits' robust loss for ReconstructOptions::robust (issue #14): the
// sweep's and the per-texel kd's (Cauchy, chosen by measurement:
// reconstruct_stage.cc); least squares when false.
fit::RobustOptions RobustFitOf(bool robust);

absl::StatusOr<v1::RunReport> RunReconstruction(const scene::Sequence& sequence, gl::EglContext& context,
                                                const ReconstructOptions& options);

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_RECONSTRUCT_STAGE_H_
