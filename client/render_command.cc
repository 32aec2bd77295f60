// `mvbrdf render DIR --camera NAME_OR_FILE --lights FILE --out IMAGE`: the
// reconstruction drawn from any camera under any lights.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
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

// What `render` draws beyond camera, lights and frame.
struct RenderFlags {
  std::string size;     // "WxH" or empty: the camera's
  bool alpha = false;   // RGBA with the coverage in alpha
  std::string frames;   // "A:B" or "A:B:STEP" or empty: --frame
  std::string ambient;  // "R,G,B" or empty
  int supersample = 1;  // subpixels per pixel side, box-averaged
  bool no_grazing_support = false;  // GGX extrapolated past the run's grazing support
};

absl::Status BadValue(const char* flag, const std::string& value, const char* expected) {
  return absl::InvalidArgumentError(
      absl::StrCat(flag, ": expected ", expected, ", got \"", scene::ShownName(value), "\""));
}

// "--size WxH": the camera drawn at another resolution with the same field
// of view (scene::Rescaled), so W:H must keep the camera's aspect ratio (to a
// pixel). Lens distortion acts on normalised coordinates and stays.
absl::Status ResizeCamera(const std::string& size, scene::CameraModel* camera) {
  int w = 0, h = 0;
  const std::vector<std::string> parts = absl::StrSplit(size, 'x');
  if (parts.size() != 2 || !absl::SimpleAtoi(parts[0], &w) || !absl::SimpleAtoi(parts[1], &h) || w < 1 || h < 1 ||
      w > 16384 || h > 16384) {
    return BadValue("--size", size, "WIDTHxHEIGHT in pixels, each in 1..16384 (e.g. 640x480)");
  }
  if (std::abs(static_cast<double>(w) * camera->height - static_cast<double>(h) * camera->width) >
      std::max(camera->width, camera->height)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--size: ", w, "x", h, " does not keep camera \"", scene::ShownName(camera->name), "\"'s aspect ratio (",
        camera->width, "x", camera->height, "); the field of view is kept, so W:H must match"));
  }
  *camera = scene::Rescaled(*camera, w, h);
  return absl::OkStatus();
}

// "--frames A:B[:STEP]": frames A, A + STEP, ... below B (0-based, as --frame).
absl::StatusOr<std::vector<int>> ParseFrames(const std::string& text, int num_frames) {
  const std::vector<std::string> parts = absl::StrSplit(text, ':');
  int a = 0, b = 0, step = 1;
  if ((parts.size() != 2 && parts.size() != 3) || !absl::SimpleAtoi(parts[0], &a) || !absl::SimpleAtoi(parts[1], &b) ||
      (parts.size() == 3 && !absl::SimpleAtoi(parts[2], &step))) {
    return BadValue("--frames", text, "A:B or A:B:STEP (frames A, A + STEP, ... below B, 0-based)");
  }
  if (step < 1) return absl::InvalidArgumentError(absl::StrCat("--frames: STEP must be >= 1, got ", step));
  if (a < 0 || b > num_frames || a >= b) {
    return absl::InvalidArgumentError(
        absl::StrCat("--frames: ", text, " must satisfy 0 <= A < B <= ", num_frames, " (the scene's frames)"));
  }
  std::vector<int> frames;
  for (int t = a; t < b; t += step) frames.push_back(t);
  return frames;
}

// "--ambient R,G,B": finite, >= 0, in the lights' units.
absl::StatusOr<glm::vec3> ParseAmbient(const std::string& text) {
  const std::vector<std::string> parts = absl::StrSplit(text, ',');
  double v[3];
  bool ok = parts.size() == 3;
  for (size_t k = 0; ok && k < 3; ++k) ok = absl::SimpleAtod(parts[k], &v[k]) && std::isfinite(v[k]) && v[k] >= 0.0;
  if (!ok) return BadValue("--ambient", text, "R,G,B: three finite numbers >= 0 (e.g. 0.1,0.1,0.1)");
  return glm::vec3(static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]));
}

absl::Status Render(const std::string& dir, const std::string& camera_arg, const std::string& lights_file, int frame,
                    bool correction, const std::string& out, gl::EglPlatform platform, const RenderFlags& options,
                    const std::string& scene_flag, std::vector<std::string>* written) {
  const std::filesystem::path run_dir = dir;
  MVBRDF_ASSIGN_OR_RETURN(const v1::RunReport run, ReadJsonFileAs<v1::RunReport>(run_dir / "result.json"));
  MVBRDF_ASSIGN_OR_RETURN(const scene::Sequence sequence, pipeline::LoadSceneOfRun(run_dir, run, scene_flag));
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
  std::vector<int> frames = {frame};
  if (!options.frames.empty()) {
    MVBRDF_ASSIGN_OR_RETURN(frames, ParseFrames(options.frames, sequence.num_frames));
    // One image per frame, named by the absolute frame: --out is a pattern.
    if (!IsFramePattern(out)) {
      return absl::InvalidArgumentError(
          absl::StrCat("--out: with --frames, expected a pattern with one printf integer "
                       "conversion numbered by the absolute frame (e.g. \"relit_%04d.png\"), got ",
                       out));
    }
    MVBRDF_RETURN_IF_ERROR(ValidateFramePattern(out, "--out"));
  }
  pipeline::ReconstructionRenderer::Extras extras;
  if (!options.ambient.empty()) {
    MVBRDF_ASSIGN_OR_RETURN(extras.ambient, ParseAmbient(options.ambient));
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
    std::vector<std::string> camera_names;
    for (const scene::CameraModel& c : sequence.cameras) camera_names.push_back(c.name);
    const std::string names = scene::NameList(camera_names);
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
  if (!options.size.empty()) MVBRDF_RETURN_IF_ERROR(ResizeCamera(options.size, &camera));
  if (options.supersample < 1 || options.supersample > 8) {
    return absl::InvalidArgumentError(
        absl::StrCat("--supersample: expected 1 to 8 subpixels per pixel side, got ", options.supersample));
  }
  // Drawn at N x N subpixels per pixel and box-averaged (as evaluate's
  // --relight-supersample): what a sensor integrating each pixel records.
  const scene::CameraModel fine = scene::Supersampled(camera, options.supersample);
  MVBRDF_ASSIGN_OR_RETURN(const std::vector<scene::Light> lights, ReadLights(lights_file));
  MVBRDF_ASSIGN_OR_RETURN(auto context, gl::EglContext::Create(platform));
  MVBRDF_ASSIGN_OR_RETURN(auto renderer, pipeline::ReconstructionRenderer::Open(run_dir, sequence, *context, !options.no_grazing_support));
  cv::Mat coverage;
  if (options.alpha) extras.coverage = &coverage;
  for (int t : frames) {
    MVBRDF_ASSIGN_OR_RETURN(cv::Mat radiance, renderer->Render(fine, lights, t, correction, extras));
    if (options.supersample > 1) {
      const cv::Size size(camera.width, camera.height);
      cv::resize(cv::Mat(radiance), radiance, size, 0, 0, cv::INTER_AREA);
      if (options.alpha) cv::resize(cv::Mat(coverage), coverage, size, 0, 0, cv::INTER_AREA);
    }
    if (options.alpha) {
      // RGBA: the coverage in alpha (straight, not premultiplied; the background's RGB is 0).
      cv::Mat rgba;
      cv::merge(std::vector<cv::Mat>{radiance, coverage}, rgba);
      radiance = rgba;
    }
    const std::filesystem::path out_path =
        options.frames.empty() ? out : FormatFramePattern(out, sequence.AbsoluteFrame(t));
    if (out_path.extension() == ".exr") {
      MVBRDF_RETURN_IF_ERROR(image::WriteExr(out_path, radiance));
    } else {
      MVBRDF_RETURN_IF_ERROR(image::WritePngPreview(out_path, radiance));
    }
    written->push_back(out_path.string());
  }
  return absl::OkStatus();
}

}  // namespace

int RunRender(const std::vector<std::string>& args) {
  std::string dir, camera, lights, out, egl = "auto", scene_flag;
  int frame = 0;
  bool correction = false;
  RenderFlags options;
  FlagParser flags("render",
                   "Draws a reconstruction (the output directory of 'mvbrdf run') from a scene camera or a\n"
                   "camera given as JSON (a mvbrdf.v1.Camera), under lights given as JSON ({\"lights\": [...]}),\n"
                   "in the pose of a frame, optionally with that frame's correction atlas.");
  flags.AddPositional("DIR", &dir, true, "the output directory of 'mvbrdf run'");
  flags.AddString("--camera NAME_OR_FILE", &camera, "a camera name of the scene, or a camera JSON file");
  flags.AddString("--lights FILE", &lights, "a JSON file with the lights");
  flags.AddInt("--frame N", &frame, "the frame whose pose is drawn (0-based)");
  flags.AddBool("--correction", &correction, "add the frame's correction atlas to kd");
  flags.AddString("--out FILE", &out,
                  "the image to write: .png (sRGB 8-bit) or .exr (linear float); with --frames a pattern numbered by "
                  "the absolute frame, e.g. relit_%04d.png");
  flags.AddString("--size WxH", &options.size,
                  "render at another resolution with the camera's field of view (intrinsics scaled; W:H as the "
                  "camera's; default: the camera's size)");
  flags.AddBool("--alpha", &options.alpha,
                "write RGBA: alpha is the mesh's coverage of the pixel (0 where it does not cover the pixel centre; "
                "with --supersample the fraction of subpixels covered)");
  flags.AddBool("--no-grazing-support", &options.no_grazing_support,
                "draw GGX lobes as glTF viewers draw the export: extrapolated towards grazing past where the "
                "capture observed them (default: each cluster held at its grazing support, result.json's "
                "clusters[].ggxGrazingSupport)");
  flags.AddInt("--supersample N", &options.supersample,
               "anti-aliasing: draw N x N subpixels per pixel (1-8) and average them, as a sensor integrates a "
               "pixel (default 1: each pixel's centre)");
  flags.AddString("--frames A:B[:STEP]", &options.frames,
                  "one image per frame A, A + STEP, ... below B (0-based, as --frame; instead of --frame)");
  flags.AddString("--ambient R,G,B", &options.ambient,
                  "a constant ambient light: every covered pixel gets kd * (R, G, B) added, kd the reconstruction's "
                  "(with --correction kd + c), in the lights' units");
  flags.AddString("--egl PLATFORM", &egl, "EGL platform: auto, surfaceless (Mesa) or device (GPU)");
  flags.AddString(
      "--scene FILE", &scene_flag,
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
  std::vector<std::string> written;
  const absl::Status s = Render(dir, camera, lights, frame, correction, out, *platform, options, scene_flag, &written);
  for (const std::string& file : written) std::printf("wrote %s\n", file.c_str());
  if (!s.ok()) return ReportFailure(s);
  return kExitOk;
}

}  // namespace mvbrdf::client
