// `mvbrdf evaluate DIR --truth TRUTH_DIR`: a reconstruction against the truth.
#include <cstdio>
#include <filesystem>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "client/commands.h"
#include "client/flags.h"
#include "client/output_dir.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/evaluate/reconstruction_evaluator.h"
#include "core/gl/egl_context.h"
#include "core/image/exr.h"
#include "core/pipeline/relighting_evaluation.h"
#include "core/scene/sequence.h"
#include "core/synth/ground_truth.h"

namespace mvbrdf::client {
namespace {

// The relighting error (issue #15) of the run against the truth.
absl::StatusOr<v1::RelightingEvaluation> Relighting(const std::filesystem::path& run_dir,
                                                    const std::filesystem::path& truth_dir,
                                                    const pipeline::RelightingOptions& options,
                                                    gl::EglPlatform platform) {
  const std::filesystem::path truth_file = evaluate::TruthFileOf(truth_dir);
  MVBRDF_ASSIGN_OR_RETURN(const synth::GroundTruth truth, synth::GroundTruth::Load(truth_file));
  MVBRDF_ASSIGN_OR_RETURN(const v1::RunReport run, ReadJsonFileAs<v1::RunReport>(run_dir / "result.json"));
  const std::optional<std::filesystem::path> scene_file = evaluate::SceneOfRun(run_dir, run, truth_file);
  if (!scene_file) {
    return absl::NotFoundError("no scene found (result.json's, or scene.json beside the truth) to draw the run from");
  }
  scene::LoadOptions load;
  load.check_all_frames = false;
  load.probe_videos = false;
  MVBRDF_ASSIGN_OR_RETURN(const scene::Sequence sequence, scene::LoadSequence(*scene_file, load));
  MVBRDF_ASSIGN_OR_RETURN(auto context, gl::EglContext::Create(platform));
  return pipeline::EvaluateRelighting(run_dir, truth, sequence, *context, options);
}

// `--relight-images DIR`: per row NNN of relighting.rows, the truth and the
// reconstruction as drawn (linear EXR), side by side as a PNG preview, the
// pixels the row's RMSE counts (PNG), and the view and light as `mvbrdf
// render --camera --lights` take them (drawn at the row's frame, `render`
// gives the reconstruction image again).
absl::Status WriteRowImages(const std::filesystem::path& dir, const pipeline::RelightingRowImages& row) {
  char stem[16];
  std::snprintf(stem, sizeof(stem), "%03d", row.row);
  const std::filesystem::path base = dir / stem;
  MVBRDF_RETURN_IF_ERROR(image::WriteExr(base.string() + "_truth.exr", *row.truth));
  MVBRDF_RETURN_IF_ERROR(image::WriteExr(base.string() + "_reconstruction.exr", *row.reconstruction));
  cv::Mat both;
  cv::hconcat(*row.truth, *row.reconstruction, both);
  MVBRDF_RETURN_IF_ERROR(image::WritePngPreview(base.string() + ".png", both));
  cv::Mat counted;
  cv::merge(std::vector<cv::Mat>{*row.counted, *row.counted, *row.counted}, counted);
  counted.convertTo(counted, CV_32FC3, 1.0 / 255.0);
  MVBRDF_RETURN_IF_ERROR(image::WritePngPreview(base.string() + "_counted.png", counted));
  v1::Camera camera;
  scene::CameraModelToProto(*row.view, &camera);
  MVBRDF_RETURN_IF_ERROR(WriteJsonFile(base.string() + "_camera.json", camera));
  v1::LightList lights;
  v1::Light* light = lights.add_lights();
  light->set_name(row.light->name);
  const glm::vec3& where = row.light->directional ? row.light->direction : row.light->position;
  for (int i = 0; i < 3; ++i) {
    (row.light->directional ? light->add_direction(where[i]) : light->add_position(where[i]));
    light->add_intensity(row.light->intensity[i]);
  }
  return WriteJsonFile(base.string() + "_lights.json", lights);
}

}  // namespace

int RunEvaluate(const std::vector<std::string>& args) {
  std::string dir, truth, error_atlas, relight_images, kd_texels_of, egl = "auto";
  bool no_relighting = false, force = false;
  pipeline::RelightingOptions relighting;
  FlagParser flags("evaluate",
                   "Compares a reconstruction (the output directory of 'mvbrdf run') with the synthetic\n"
                   "generator's ground truth and prints JSON: configuration_correct, kd_rmse (texels seen at\n"
                   "least 10 times), per cluster ks and ke relative errors, cluster_accuracy; per camera the\n"
                   "rotation, centre and reprojection error of the scene's calibration (before) and of the cameras\n"
                   "as used (after, refined), per light its position, direction and intensity error (intensities\n"
                   "after one common scale: the data cannot tell it from kd's); and the relighting error: the\n"
                   "reconstruction and the truth drawn from views between the cameras under lights the capture\n"
                   "did not use (RMSE in linear radiance, overall, per material and per view and light): the\n"
                   "figure that scores a model when the truth is measured (synth --materials).");
  flags.AddPositional("DIR", &dir, true, "the output directory of 'mvbrdf run'");
  flags.AddString("--truth DIR", &truth, "the synthetic bundle (or its ground_truth/ directory)");
  flags.AddString("--error-atlas FILE", &error_atlas, "also write the per-texel kd error (.png, x10, or .exr)");
  flags.AddString("--kd-texels-of RUN", &kd_texels_of,
                  "take kdRmse (and the kd medians and the clusters' kdRmse) over the texels another run of the same "
                  "scene saw at least 10 times, with this run's kd there: two runs compared on the same texels "
                  "(a run that rejects observations otherwise counts fewer, easier texels)");
  flags.AddBool("--no-relighting", &no_relighting, "leave out the relighting error (it renders; needs EGL)");
  flags.AddInt("--relight-views N", &relighting.views, "held-out views for the relighting error (default 4)");
  flags.AddInt("--relight-lights N", &relighting.lights, "held-out lights, each alone (default 3)");
  flags.AddInt("--relight-frame T", &relighting.frame, "the frame drawn (default: the middle one)");
  flags.AddInt("--relight-supersample N", &relighting.supersample,
               "subpixels per pixel side, 1-8: both images drawn at N times the views' resolution and "
               "box-averaged, as a sensor integrates a pixel (a pixel counts when all its subpixels would); "
               "default 1: each pixel's centre, as synth draws the frames");
  bool no_grazing_support = false;
  flags.AddBool("--no-grazing-support", &no_grazing_support,
                "draw the reconstruction's GGX lobes as glTF viewers draw the export, extrapolated towards grazing "
                "past where the capture observed them (default: each cluster held at its grazing support, "
                "result.json's clusters[].ggxGrazingSupport, as mvbrdf render and the report draw them)");
  flags.AddString("--relight-images DIR",
                  &relight_images,
                  "also write each relighting row's images to DIR (new or empty): NNN_truth.exr, "
                  "NNN_reconstruction.exr, NNN.png (both side by side), NNN_counted.png (the pixels its RMSE "
                  "counts), NNN_camera.json and NNN_lights.json (render --camera --lights at the row's frame draws "
                  "the reconstruction again); NNN is the row's index in relighting.rows");
  flags.AddBool("--force", &force, std::string(kForceHelp) + " (--relight-images)");
  flags.AddString("--egl PLATFORM", &egl, "EGL platform: auto, surfaceless (Mesa) or device (GPU)");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf evaluate: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  relighting.grazing_support = !no_grazing_support;
  if (truth.empty()) {
    std::fprintf(stderr, "mvbrdf evaluate: --truth: required\n");
    return kExitUsage;
  }
  if (!error_atlas.empty()) {
    // The error atlas and its "_truth_kd" sibling must not replace a file of
    // the run or its scene (--error-atlas DIR/atlases/kd.exr exited 0 and
    // destroyed the reconstruction).
    std::vector<InputPath> inputs = RunInputs(dir);
    inputs.push_back({"--truth", std::filesystem::path(truth) / "truth.json", false});
    inputs.push_back({"--truth", std::filesystem::path(truth) / "ground_truth" / "truth.json", false});
    std::filesystem::path sibling = error_atlas;
    sibling.replace_filename(sibling.stem().string() + "_truth_kd" + sibling.extension().string());
    for (const std::filesystem::path& file : {std::filesystem::path(error_atlas), sibling}) {
      if (absl::Status s = CheckOutputFileSparesInputs("--error-atlas", file, inputs); !s.ok()) {
        return ReportFailure(s);
      }
    }
  }
  auto platform = gl::ParseEglPlatform(egl);
  if (!platform.ok()) {
    std::fprintf(stderr, "mvbrdf evaluate: %s\n", std::string(platform.status().message()).c_str());
    return kExitUsage;
  }
  if (relighting.views < 1 || relighting.lights < 1) {
    std::fprintf(stderr, "mvbrdf evaluate: --relight-views and --relight-lights: must be >= 1\n");
    return kExitUsage;
  }
  if (relighting.supersample < 1 || relighting.supersample > 8) {
    std::fprintf(stderr, "mvbrdf evaluate: --relight-supersample: expected 1 to 8, got %d\n", relighting.supersample);
    return kExitUsage;
  }
  std::optional<OutputDirLock> images_lock;
  if (!relight_images.empty()) {
    if (no_relighting) {
      std::fprintf(stderr, "mvbrdf evaluate: --relight-images: leave out --no-relighting (there are no rows)\n");
      return kExitUsage;
    }
    std::vector<InputPath> inputs = RunInputs(dir);
    inputs.push_back({"--truth", std::filesystem::path(truth) / "truth.json", false});
    inputs.push_back({"--truth", std::filesystem::path(truth) / "ground_truth" / "truth.json", false});
    if (absl::Status s = CheckOutputDirSparesInputs("--relight-images", relight_images, inputs); !s.ok()) {
      return ReportFailure(s);
    }
    absl::StatusOr<OutputDirLock> lock = PrepareOutputDir("--relight-images", relight_images, force);
    if (!lock.ok()) return ReportFailure(lock.status());
    images_lock.emplace(std::move(*lock));
    relighting.on_row = [&relight_images](const pipeline::RelightingRowImages& row) {
      return WriteRowImages(relight_images, row);
    };
  }
  auto report = evaluate::EvaluateReconstruction(dir, truth, error_atlas, {}, kd_texels_of);
  if (!report.ok()) return ReportFailure(report.status());
  if (!no_relighting && report->clusters_size() > 0) {
    auto relit = Relighting(dir, truth, relighting, *platform);
    if (!relit.ok()) return ReportFailure(relit.status());
    *report->mutable_relighting() = *relit;
  }
  std::fputs(MessageToJsonWithDefaults(*report).c_str(), stdout);  // "configurationCorrect": false too
  std::fputs("\n", stdout);
  return kExitOk;
}

}  // namespace mvbrdf::client
