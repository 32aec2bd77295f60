// `mvbrdf synth`: render a synthetic multi-view sequence with ground truth.
#include <cstdio>
#include <cstdlib>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/flags.h"
#include "client/output_dir.h"
#include "core/gl/egl_context.h"
#include "core/synth/synthesizer.h"

namespace mvbrdf::client {

int RunSynth(const std::vector<std::string>& args) {
  synth::SynthOptions o;
  std::string preset = "actor";
  std::string out;
  bool force = false;
  std::string format = "ffv1";
  std::string egl = "auto";
  std::string lighting = "studio";
  std::string camera_model = "pinhole";
  std::string brdf_model = "phong";
  const char* env_data = std::getenv("MVBRDF_DATA_DIR");
  std::string data_dir = env_data != nullptr ? env_data : MVBRDF_DEFAULT_DATA_DIR;
  FlagParser flags("synth",
                   "Renders a synthetic multi-view sequence in a studio like the thesis's (8 cameras on a ring,\n"
                   "9 ceiling lights, one light configuration active) and writes DIR/scene.json, the videos,\n"
                   "the meshes and DIR/ground_truth/ (lights, cameras, materials as rendered).");
  flags.AddString("--preset NAME", &preset,
                  "actor (procedural, no data needed), sphere (a static UV sphere of one material, no data), spot or "
                  "samba (read from --data)");
  flags.AddString("--out DIR", &out, "output directory (required)");
  flags.AddBool("--force", &force, kForceHelp);
  flags.AddInt("--cameras N", &o.num_cameras, "number of cameras on the ring");
  flags.AddInt("--frames N", &o.num_frames, "number of frames");
  flags.AddInt("--width PIXELS", &o.width, "image width in pixels");
  flags.AddInt("--height PIXELS", &o.height, "image height in pixels");
  flags.AddDouble("--fps FPS", &o.fps, "frames per second");
  flags.AddDouble("--noise SIGMA", &o.noise_sigma, "sensor noise sigma in 8-bit code values");
  flags.AddString("--config NAME", &o.configuration,
                  "active light configuration, e.g. \"NE,NW,SE,SW\" (the default) or \"C\"; with --dome \"all\" "
                  "(the default) or dome light names, e.g. \"D000,D007\"");
  flags.AddInt("--dome N", &o.dome,
               "N > 0: N directional lights D000.. spread over the upper hemisphere replace the 9 ceiling lights "
               "(with --lighting olat frame t is lit by dome light t mod N); 0: the ceiling lights");
  flags.AddString("--lighting MODE", &lighting,
                  "studio (every frame lit by --config) or olat (one light at a time: frame t by ceiling light "
                  "t mod 9, or dome light t mod N; in scene.json's frameLighting and the truth)");
  flags.AddString("--camera-model MODEL", &camera_model,
                  "pinhole or orthographic (telecentric: the same ring of viewpoints, the pixel size the "
                  "pinhole's at the subject; scene.json's cameras[].model and pixelSize, and the truth)");
  flags.AddUint("--seed N", &o.seed, "random seed (noise, perturbations)");
  flags.AddString("--format FORMAT", &format, "ffv1 (lossless .mkv) or png (image sequences)");
  flags.AddBool("--lossy", &o.lossy_video, "write lossy MPEG-4 video instead (a perturbation)");
  flags.AddDouble("--camera-rotation-error DEGREES", &o.camera_rotation_error_deg,
                  "calibration error: rotate the scene's cameras by this many degrees");
  flags.AddDouble("--camera-translation-error DISTANCE", &o.camera_translation_error,
                  "calibration error: move the scene's cameras by this distance");
  flags.AddDouble("--vertex-noise DISTANCE", &o.vertex_noise,
                  "render geometry displaced by this amplitude that the scene's mesh does not model");
  flags.AddDouble("--normal-detail SLOPE", &o.normal_detail,
                  "surface detail the mesh does not model: shading normals tilted by bumps of this peak slope "
                  "(0.3: ~17 degrees) about 8 % of the subject's size across, recorded in the truth (issue #18); "
                  "a subject without UVs gets an atlas's, written into the meshes");
  flags.AddDouble("--exposure GAIN", &o.exposure, "gain before 8-bit clipping; > 1 clips highlights");
  flags.AddDouble("--distortion K1", &o.distortion_k1, "radial distortion k1 of every camera");
  flags.AddString("--brdf MODEL", &brdf_model,
                  "reflectance model rendered: phong (the thesis's, default), blinn-phong or ggx (glTF's "
                  "metallic-roughness lobe); the presets' materials converted as core/synth/model_materials.h says, "
                  "the truth records the model's parameters");
  flags.AddString("--materials LIST", &o.materials,
                  "measured materials (MERL, as neural BRDFs) for the preset's material slots: SLOT=NAME or NAME "
                  "for the next slot, comma-separated, - keeps a slot analytic (e.g. cloth=blue-fabric,skin=-,"
                  "hair=black-oxidized-steel; one NAME for sphere or spot); the truth is then no analytic model");
  std::string merl_file, measured_exposure = "albedo";
  flags.AddString("--measured-exposure MODE", &measured_exposure,
                  "albedo (default: each measured material as bright as its slot's; glossy highlights may clip, as "
                  "in an 8-bit capture exposed for the diffuse) or highlights (no highlight clips under the "
                  "brightest light; use with --bit-depth 16)");
  flags.AddInt("--bit-depth N", &o.bit_depth, "bits per channel of the frames: 8 (default) or 16 (with --format png)");
  flags.AddString("--merl-file FILE", &merl_file,
                  "merl_nbrdf.json holding the measured materials (default: env MVBRDF_MERL_NBRDF, else "
                  "DATA/merl_nbrdf/ or ../shared/data/merl_nbrdf/)");
  flags.AddInt("--pixel-samples N", &o.pixel_samples,
               "N x N samples per pixel averaged in linear light, as a sensor integrates its pixel (1: one at the "
               "centre, aliased edges; up to 8)");
  flags.AddDouble("--light-position-error DISTANCE", &o.light_position_error,
                  "each point light written to scene.json moved this far in a random direction (truth: as rendered)");
  flags.AddDouble("--light-direction-error DEGREES", &o.light_direction_error_deg,
                  "each directional light written to scene.json turned by this angle about a random axis");
  flags.AddDouble("--light-intensity-error FRACTION", &o.light_intensity_error,
                  "each light's intensity written to scene.json scaled by 1 + or - this (random sign)");
  flags.AddInt("--actor-segments N", &o.actor_segments, "actor tessellation (24: ~8k triangles, 48: ~35k)");
  flags.AddInt("--shadow-map-size N", &o.shadow_map_size, "shadow map resolution per cube face");
  flags.AddString("--data DIR", &data_dir, "directory holding spot/ and samba/ (env MVBRDF_DATA_DIR)");
  flags.AddString("--egl PLATFORM", &egl, "EGL platform: auto, surfaceless (Mesa) or device (GPU)");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf synth: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  auto parsed_preset = synth::ParsePreset(preset);
  auto platform = gl::ParseEglPlatform(egl);
  auto parsed_lighting = synth::ParseLighting(lighting);
  auto parsed_camera_model = synth::ParseCameraModel(camera_model);
  absl::StatusOr<brdf::Model> parsed_brdf = brdf::ParseModel(brdf_model);
  if (!parsed_brdf.ok()) parsed_brdf = absl::InvalidArgumentError(absl::StrCat("--brdf: ", parsed_brdf.status().message()));
  for (const absl::Status& s : {parsed_preset.status(), platform.status(), parsed_lighting.status(),
                                parsed_camera_model.status(), parsed_brdf.status()}) {
    if (!s.ok()) {
      std::fprintf(stderr, "mvbrdf synth: %s\n", std::string(s.message()).c_str());
      return kExitUsage;
    }
  }
  if (format != "ffv1" && format != "png") {
    std::fprintf(stderr, "mvbrdf synth: --format: expected ffv1 or png, got \"%s\"\n", format.c_str());
    return kExitUsage;
  }
  o.preset = *parsed_preset;
  o.lighting = *parsed_lighting;
  o.camera_model = *parsed_camera_model;
  o.brdf = *parsed_brdf;
  o.video_format = format == "png" ? synth::VideoFormat::kPng : synth::VideoFormat::kFfv1;
  o.out_dir = out;
  o.data_dir = data_dir;
  o.merl_file = merl_file;
  if (measured_exposure != "albedo" && measured_exposure != "highlights") {
    std::fprintf(stderr, "mvbrdf synth: --measured-exposure: expected albedo or highlights, got \"%s\"\n",
                 measured_exposure.c_str());
    return kExitUsage;
  }
  o.measured_exposure = measured_exposure == "highlights" ? synth::SynthOptions::MeasuredExposure::kHighlights
                                                          : synth::SynthOptions::MeasuredExposure::kAlbedo;
  if (absl::Status s = o.Check(); !s.ok()) {
    std::fprintf(stderr, "mvbrdf synth: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }

  // One writer per directory, as run and resample (two synths into one --out would mix their files).
  absl::StatusOr<OutputDirLock> lock = PrepareOutputDir("--out", out, force);
  if (!lock.ok()) return ReportFailure(lock.status(), "mvbrdf synth");
  auto context = gl::EglContext::Create(*platform);
  if (!context.ok()) {
    std::fprintf(stderr, "mvbrdf synth: error: %s\n", std::string(context.status().message()).c_str());
    return kExitEnvironment;
  }
  std::printf("rendering on %s\n", (*context)->Describe().c_str());
  auto result = synth::Synthesize(o, **context);
  if (!result.ok()) return ReportFailure(result.status());
  std::printf("wrote %s: %s preset, %d triangles, %d cameras x %d frames (%d images) in %.1f s\n",
              result->scene_file.c_str(), synth::PresetName(o.preset), result->num_triangles, o.num_cameras,
              o.num_frames, result->frames_rendered, result->seconds);
  std::printf("ground truth: %s (active configuration %s)\n",
              (result->scene_file.parent_path() / "ground_truth" / "truth.json").c_str(),
              result->truth.active_configuration().c_str());
  return kExitOk;
}

}  // namespace mvbrdf::client
