#include "core/report/report_inputs.h"

#include <cmath>
#include <fstream>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/calibrate/refine_cameras.h"
#include "core/evaluate/reconstruction_evaluator.h"
#include "core/image/exr.h"
#include "core/pipeline/reconstruction_renderer.h"
#include "core/pipeline/relighting_evaluation.h"
#include "core/synth/ground_truth.h"
#include "core/pipeline/run_scene.h"
#include "core/scene/sequence.h"
#include "core/scene/video_source.h"

namespace mvbrdf::report {
namespace {

namespace fs = std::filesystem;

// A preview's PNG bytes, encoded in memory: no file is named after a camera.
absl::StatusOr<std::string> Png(const cv::Mat& linear, float gain = 1.0f) {
  return image::EncodePngPreview(linear, gain);
}

// The scene's lights of configuration `name` (every light when unknown).
std::vector<scene::Light> LightsOf(const scene::Sequence& sequence, const std::string& name) {
  std::vector<scene::Light> lights;
  for (const v1::LightConfiguration& c : sequence.scene.light_configurations()) {
    if (c.name() != name) continue;
    for (const std::string& l : c.lights()) {
      for (const scene::Light& light : sequence.lights) {
        if (light.name == l) lights.push_back(light);
      }
    }
  }
  return lights.empty() ? sequence.lights : lights;
}

absl::Status AddRenderings(const fs::path& run_dir, const v1::RunReport& run, const ReportOptions& options,
                           ReportInputs* in) {
  MVBRDF_ASSIGN_OR_RETURN(scene::Sequence sequence, pipeline::LoadSceneOfRun(run_dir, run, options.scene));
  // Rendered with the cameras as the run used them (issue #14: refined).
  MVBRDF_RETURN_IF_ERROR(calibrate::ApplyCameraRefinement(run.calibration(), &sequence));
  MVBRDF_ASSIGN_OR_RETURN(auto renderer, pipeline::ReconstructionRenderer::Open(run_dir, sequence, *options.gl));
  const int frame = sequence.num_frames / 2;
  // The input frame is lit by its own lights where scene.frame_lighting has
  // them, else by the run's configuration.
  std::vector<scene::Light> lights = LightsOf(sequence, run.chosen_configuration());
  if (const v1::FrameLighting* own = sequence.FrameLightingOf(frame); own != nullptr) {
    lights.clear();
    for (const std::string& name : own->lights()) {
      const int k = sequence.FindLight(name);
      if (k >= 0) lights.push_back(sequence.lights[static_cast<size_t>(k)]);
    }
  }
  char correction_name[32];
  std::snprintf(correction_name, sizeof(correction_name), "%04d.exr",
                sequence.AbsoluteFrame(frame));
  const bool has_correction = fs::exists(run_dir / "atlases" / "correction" / correction_name);
  const int cameras = std::min<int>(options.max_cameras, static_cast<int>(sequence.cameras.size()));
  for (int c = 0; c < cameras; ++c) {
    const scene::CameraModel& camera = sequence.cameras[static_cast<size_t>(c)];
    CameraComparison cmp;
    cmp.camera = camera.name;
    cmp.frame = frame;
    MVBRDF_ASSIGN_OR_RETURN(auto video, scene::VideoSource::Open(sequence.scene.cameras(c), sequence.scene_dir,
                                                                 sequence.frames, sequence.num_frames,
                                                                 absl::StrCat("scene.cameras[", c, "]")));
    MVBRDF_ASSIGN_OR_RETURN(cv::Mat input, video->ReadFrame(frame));
    // Shown as stored: a saturated pixel white, a masked one black (the
    // decoder marks both negative, scene::kSaturatedPixel / kMaskedPixel).
    input.forEach<cv::Vec3f>([](cv::Vec3f& p, const int*) {
      if (p[0] < 0.0f) p = cv::Vec3f::all(p[0] == scene::kSaturatedPixel ? 1.0f : 0.0f);
    });
    MVBRDF_ASSIGN_OR_RETURN(cmp.input_png, Png(input));
    MVBRDF_ASSIGN_OR_RETURN(const cv::Mat brdf, renderer->Render(camera, lights, frame, false));
    MVBRDF_ASSIGN_OR_RETURN(cmp.reconstruction_png, Png(brdf));
    if (has_correction) {
      MVBRDF_ASSIGN_OR_RETURN(const cv::Mat corrected, renderer->Render(camera, lights, frame, true));
      MVBRDF_ASSIGN_OR_RETURN(cmp.corrected_png, Png(corrected));
    }
    in->cameras.push_back(std::move(cmp));
  }
  // Thesis Fig. 7.7: one point light moving around the model, kept on the
  // camera's side (a light behind the model leaves the view black).
  glm::vec3 lo(INFINITY), hi(-INFINITY);
  for (const glm::vec3& p : sequence.rest_positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  glm::vec3 intensity(0.0f);
  for (const scene::Light& l : lights) intensity += l.intensity;
  intensity *= 0.6f;  // most of the configuration's light from one place
  if (sequence.cameras.empty()) return absl::OkStatus();
  const std::vector<RelitLight> path = RelitLightPath(sequence.cameras[0], lo, hi, options.relit_frames);
  for (const RelitLight& step : path) {
    scene::Light light;
    light.name = "orbit";
    light.position = step.position;
    light.intensity = intensity;
    MVBRDF_ASSIGN_OR_RETURN(const cv::Mat relit, renderer->Render(sequence.cameras[0], {light}, frame, false));
    MVBRDF_ASSIGN_OR_RETURN(std::string png, Png(relit));
    in->relit.push_back({absl::StrCat(step.degrees, "° from the camera"), std::move(png)});
  }
  return absl::OkStatus();
}

}  // namespace

std::vector<RelitLight> RelitLightPath(const scene::CameraModel& camera, const glm::vec3& lo, const glm::vec3& hi,
                                       int frames) {
  std::vector<RelitLight> path;
  if (frames <= 0) return path;
  const glm::vec3 centre = 0.5f * (lo + hi);
  const float radius = 1.5f * glm::length(hi - lo);
  // The camera's axes in the world: right (x) and up (-y, OpenCV's y points down).
  const glm::dmat3 world_from_cam = glm::transpose(camera.cam_from_world_rotation);
  const glm::vec3 right = glm::normalize(glm::vec3(world_from_cam[0]));
  const glm::vec3 up = -glm::normalize(glm::vec3(world_from_cam[1]));
  glm::vec3 towards = glm::vec3(camera.ViewDirection(glm::dvec3(centre)));  // model -> camera
  towards -= glm::dot(towards, up) * up;
  towards = glm::length(towards) > 1e-6f ? glm::normalize(towards) : glm::cross(right, up);
  constexpr float kPi = 3.14159265f;
  constexpr float kSwing = 80.0f;      // degrees either side of the camera
  constexpr float kElevation = 25.0f;  // degrees above the model's centre, towards the camera's up
  const float e = kElevation * kPi / 180.0f;
  for (int k = 0; k < frames; ++k) {
    const float degrees = frames == 1 ? 0.0f : -kSwing + 2.0f * kSwing * static_cast<float>(k) / (frames - 1);
    const float a = degrees * kPi / 180.0f;
    const glm::vec3 around = std::cos(a) * towards + std::sin(a) * right;
    path.push_back(
        {centre + radius * (std::cos(e) * around + std::sin(e) * up), static_cast<int>(std::lround(degrees))});
  }
  return path;
}

absl::StatusOr<ReportInputs> CollectReportInputs(const fs::path& run_dir, const ReportOptions& options) {
  ReportInputs in;
  MVBRDF_RETURN_IF_ERROR(ReadJsonFile(run_dir / "result.json", &in.run));
  std::error_code ec;
  fs::create_directories(options.scratch_dir, ec);
  if (ec) return absl::FailedPreconditionError(absl::StrCat(options.scratch_dir.string(), ": ", ec.message()));

  for (const auto& [name, caption] : std::vector<std::pair<std::string, std::string>>{
           {"kd", "kd (diffuse)"},
           {"ks", "ks (specular)"},
           {"ke", "ke (exponent, /100)"},
           {"f0", "f0 (GGX)"},
           {"roughness", "roughness (GGX)"},
           {"f90_ratio", "F90 / F0 (GGX, /25)"},
           {"parameter_1", "each texel's model's first parameter (--brdf auto: ks or f0)"},
           {"parameter_2", "each texel's model's second parameter, /100 (--brdf auto: ke or roughness)"},
           {"parameter_3", "each texel's model's third parameter, /25 (--brdf auto: GGX's F90 / F0)"},
           {"cluster", "clusters"},
           {"normal", "normals (tangent space, (n + 1) / 2; flat blue: the mesh's)"}}) {
    const fs::path file = run_dir / "atlases" / (name + ".png");
    if (!fs::exists(file)) continue;
    MVBRDF_ASSIGN_OR_RETURN(std::string png, ReadFileToString(file));
    in.atlases.push_back({caption, std::move(png)});
  }
  if (fs::exists(run_dir / "atlases" / "confidence.exr")) {
    MVBRDF_ASSIGN_OR_RETURN(const image::ExrImage confidence, image::ReadExr(run_dir / "atlases" / "confidence.exr"));
    double max_count = 0.0;
    cv::minMaxLoc(confidence.image, nullptr, &max_count);
    cv::Mat scaled;
    cv::log(confidence.image + 1.0f, scaled);
    MVBRDF_ASSIGN_OR_RETURN(std::string png, Png(scaled, static_cast<float>(1.0 / std::log(max_count + 1.0 + 1e-9))));
    in.atlases.push_back({absl::StrCat("confidence (observations, log scale, max ", max_count, ")"), std::move(png)});
  }

  // The ground truth.
  fs::path truth = options.truth;
  if (truth.empty() && options.use_truth) {
    if (absl::StatusOr<fs::path> scene_file = pipeline::SceneOfRun(run_dir, in.run, options.scene); scene_file.ok()) {
      const fs::path beside = scene_file->parent_path();
      if (fs::exists(beside / "ground_truth" / "truth.json")) truth = beside;
    }
  }
  if (!truth.empty()) {
    const fs::path error_png = options.scratch_dir / "kd_error.png";
    MVBRDF_ASSIGN_OR_RETURN(in.evaluation, evaluate::EvaluateReconstruction(run_dir, truth, error_png, options.scene));
    // The relighting error (issue #15), where the report may render.
    if (options.gl != nullptr && in.evaluation->clusters_size() > 0 && fs::exists(run_dir / "atlases" / "kd.exr")) {
      MVBRDF_ASSIGN_OR_RETURN(const synth::GroundTruth ground_truth,
                              synth::GroundTruth::Load(evaluate::TruthFileOf(truth)));
      if (const std::optional<fs::path> scene_file =
              evaluate::SceneOfRun(run_dir, in.run, evaluate::TruthFileOf(truth), options.scene)) {
        scene::LoadOptions load;
        load.check_all_frames = false;
        load.probe_videos = false;
        MVBRDF_ASSIGN_OR_RETURN(const scene::Sequence sequence, scene::LoadSequence(*scene_file, load));
        MVBRDF_ASSIGN_OR_RETURN(*in.evaluation->mutable_relighting(),
                                pipeline::EvaluateRelighting(run_dir, ground_truth, sequence, *options.gl));
      }
    }
    if (fs::exists(error_png)) {  // runs with atlases
      MVBRDF_ASSIGN_OR_RETURN(std::string png, ReadFileToString(error_png));
      in.atlases.push_back({"|kd - kd true| ×10", std::move(png)});
    }
    if (fs::exists(options.scratch_dir / "kd_error_truth_kd.png")) {
      MVBRDF_ASSIGN_OR_RETURN(std::string truth_png, ReadFileToString(options.scratch_dir / "kd_error_truth_kd.png"));
      in.atlases.push_back({"kd true", std::move(truth_png)});
    }
  }
  if (!options.tradeoff.empty()) {
    v1::TradeoffReport tradeoff;
    MVBRDF_RETURN_IF_ERROR(ReadJsonFile(options.tradeoff, &tradeoff));
    in.tradeoff = std::move(tradeoff);
  }
  // Renderings need the BRDF atlases (a light-table-only run has none).
  if (options.gl != nullptr && fs::exists(run_dir / "atlases" / "kd.exr")) {
    MVBRDF_RETURN_IF_ERROR(AddRenderings(run_dir, in.run, options, &in));
  }
  return in;
}

}  // namespace mvbrdf::report
