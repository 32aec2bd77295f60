// `mvbrdf render DIR --camera NAME_OR_FILE --lights FILE --out IMAGE`: the
// reconstruction drawn from any camera under any lights.
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/flags.h"
#include "client/output_dir.h"
#include "core/atlas/atlas.h"
#include "core/base/files.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/gl/egl_context.h"
#include "core/image/exr.h"
#include "core/pipeline/reconstruction_renderer.h"
#include "core/pipeline/run_scene.h"
#include "core/scene/names.h"
#include "core/scene/sequence.h"
#include "core/synth/frame_encoder.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::client {
namespace {

absl::StatusOr<std::vector<scene::Light>> ReadLights(const std::string& file) {
  MVBRDF_ASSIGN_OR_RETURN(const v1::LightList list, ReadJsonFileAs<v1::LightList>(file));
  if (list.lights_size() == 0) return absl::InvalidArgumentError(absl::StrCat(file, ": lights: expected at least one"));
  // The scene's validation gives the same checks and messages as for scenes.
  v1::Scene probe;
  probe.mutable_mesh()->set_path("x.obj");
  probe.mutable_frames()->set_count(1);
  probe.mutable_frames()->set_fps(1);
  v1::Camera* cam = probe.add_cameras();
  cam->set_name("c");
  cam->set_width(1);
  cam->set_height(1);
  cam->mutable_intrinsics()->set_fx(1);
  cam->mutable_intrinsics()->set_fy(1);
  for (double r : {1, 0, 0, 0, 1, 0, 0, 0, 1}) cam->mutable_cam_from_world()->add_rotation(r);
  for (int i = 0; i < 3; ++i) cam->mutable_cam_from_world()->add_translation(0);
  cam->mutable_video()->set_path("v.mkv");
  *probe.mutable_lights() = list.lights();
  if (absl::Status s = scene::ValidateSceneMessage(probe); !s.ok()) {
    // The checks are the scene's; the field is the file's ("lights[0]...", not "scene.lights[0]...").
    std::string message(s.message());
    if (absl::StartsWith(message, "scene.lights")) message = message.substr(6);
    return absl::InvalidArgumentError(absl::StrCat(file, ": ", message));
  }
  std::vector<scene::Light> lights;
  for (const v1::Light& l : list.lights()) {
    scene::Light light;
    light.name = l.name();
    light.directional = l.direction_size() == 3;
    if (l.position_size() == 3) light.position = {l.position(0), l.position(1), l.position(2)};
    if (light.directional) light.direction = glm::normalize(glm::vec3(l.direction(0), l.direction(1), l.direction(2)));
    if (l.intensity_size() == 3) light.intensity = {l.intensity(0), l.intensity(1), l.intensity(2)};
    lights.push_back(light);
  }
  return lights;
}

absl::Status Render(const std::string& dir, const std::string& camera_arg, const std::string& lights_file, int frame,
                    bool correction, const std::string& out, gl::EglPlatform platform, const std::string& scene_flag) {
  const std::filesystem::path run_dir = dir;
  MVBRDF_ASSIGN_OR_RETURN(const v1::RunReport run, ReadJsonFileAs<v1::RunReport>(run_dir / "result.json"));
  scene::LoadOptions load;
  load.check_all_frames = false;
  load.probe_videos = false;
  MVBRDF_ASSIGN_OR_RETURN(const std::filesystem::path scene_file, pipeline::SceneOfRun(run_dir, run, scene_flag));
  MVBRDF_ASSIGN_OR_RETURN(const scene::Sequence sequence, scene::LoadSequence(scene_file, load));
  {
    // Up front: --out is a .png or .exr, and not a file render reads.
    const std::filesystem::path out_path = out;
    if (out_path.extension() != ".exr" && out_path.extension() != ".png") {
      return absl::InvalidArgumentError(absl::StrCat("--out: expected a .png or .exr file, got ", out));
    }
    std::vector<InputPath> inputs = SceneInputs(sequence);
    for (InputPath& input : RunInputs(run_dir)) inputs.push_back(std::move(input));
    inputs.push_back({"--lights", lights_file, false});
    inputs.push_back({"--camera", camera_arg, false});
    MVBRDF_RETURN_IF_ERROR(CheckOutputFileSparesInputs("--out", out_path, inputs));
    std::error_code ec;
    if (std::filesystem::is_directory(out_path, ec)) {
      return absl::InvalidArgumentError(absl::StrCat("--out ", out, ": is a directory, expected an image file name"));
    }
  }
  if (frame < 0 || frame >= sequence.num_frames) {
    return absl::InvalidArgumentError(absl::StrCat("--frame: must be in [0, ", sequence.num_frames, "), got ", frame));
  }
  scene::CameraModel camera;
  bool found = false;
  for (const scene::CameraModel& c : sequence.cameras) {
    if (c.name == camera_arg) {
      camera = c;
      found = true;
    }
  }
  if (!found && WhyNotRegularFile(camera_arg) == "not found") {
    std::string names;
    for (const scene::CameraModel& c : sequence.cameras) {
      absl::StrAppend(&names, names.empty() ? "" : ", ", "\"", scene::ShownName(c.name), "\"");
    }
    return absl::InvalidArgumentError(absl::StrCat("--camera: \"", scene::ShownName(camera_arg),
                                                   "\" is neither a camera of the scene (", names,
                                                   ") nor a camera JSON file"));
  }
  if (!found) {
    MVBRDF_ASSIGN_OR_RETURN(const v1::Camera message, ReadJsonFileAs<v1::Camera>(camera_arg));
    // As a scene's cameras are checked: a NaN or non-orthonormal rotation,
    // an infinite cx or 3 distortion values rendered silently.
    MVBRDF_RETURN_IF_ERROR(
        scene::ValidateCameraGeometry(message, absl::StrCat("--camera ", scene::ShownName(camera_arg), ": camera")));
    camera = scene::CameraModelFromProto(message);
  }
  MVBRDF_ASSIGN_OR_RETURN(const std::vector<scene::Light> lights, ReadLights(lights_file));
  MVBRDF_ASSIGN_OR_RETURN(auto context, gl::EglContext::Create(platform));
  MVBRDF_ASSIGN_OR_RETURN(auto renderer, pipeline::ReconstructionRenderer::Open(run_dir, sequence, *context));
  MVBRDF_ASSIGN_OR_RETURN(const cv::Mat radiance, renderer->Render(camera, lights, frame, correction));
  const std::filesystem::path out_path = out;
  if (out_path.extension() == ".exr") return image::WriteExr(out_path, radiance);
  if (out_path.extension() == ".png") return image::WritePngPreview(out_path, radiance);
  return absl::InvalidArgumentError(absl::StrCat("--out: expected a .png or .exr file, got ", out));
}

}  // namespace

int RunRender(const std::vector<std::string>& args) {
  std::string dir, camera, lights, out, egl = "auto", scene_flag;
  int frame = 0;
  bool correction = false;
  FlagParser flags("render",
                   "Draws a reconstruction (the output directory of 'mvbrdf run') from a scene camera or a\n"
                   "camera given as JSON (a mvbrdf.v1.Camera), under lights given as JSON ({\"lights\": [...]}),\n"
                   "in the pose of a frame, optionally with that frame's correction atlas.");
  flags.AddPositional("DIR", &dir, true, "the output directory of 'mvbrdf run'");
  flags.AddString("--camera", &camera, "a camera name of the scene, or a camera JSON file");
  flags.AddString("--lights", &lights, "a JSON file with the lights");
  flags.AddInt("--frame", &frame, "the frame whose pose is drawn (0-based)");
  flags.AddBool("--correction", &correction, "add the frame's correction atlas to kd");
  flags.AddString("--out", &out, "the image to write: .png (sRGB 8-bit) or .exr (linear float)");
  flags.AddString("--egl", &egl, "EGL platform: auto, surfaceless (Mesa) or device (GPU)");
  flags.AddString(
      "--scene", &scene_flag,
      "the scene file (default: result.json's scene, relative to DIR; needed for a fetched service result)");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf render: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  auto platform = gl::ParseEglPlatform(egl);
  std::string missing = camera.empty() ? "--camera" : lights.empty() ? "--lights" : out.empty() ? "--out" : "";
  if (!platform.ok() || !missing.empty()) {
    std::fprintf(stderr, "mvbrdf render: %s\n",
                 !platform.ok() ? std::string(platform.status().message()).c_str() : (missing + ": required").c_str());
    return kExitUsage;
  }
  const absl::Status s = Render(dir, camera, lights, frame, correction, out, *platform, scene_flag);
  if (!s.ok()) return ReportFailure(s);
  std::printf("wrote %s\n", out.c_str());
  return kExitOk;
}

}  // namespace mvbrdf::client
