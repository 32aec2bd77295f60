// `mvbrdf resample SCENE --out DIR`: every video frame into the texture atlas.
#include <cmath>
#include <cstdio>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/flags.h"
#include "client/output_dir.h"
#include "client/progress.h"
#include "core/gl/egl_context.h"
#include "core/pipeline/memory_estimate.h"
#include "core/pipeline/resample_stage.h"
#include "core/scene/sequence.h"

namespace mvbrdf::client {

int RunResample(const std::vector<std::string>& args) {
  std::string scene_file, out, save = "first", egl = "auto";
  pipeline::ResampleStageOptions o;
  bool no_evaluate = false, force = false;
  FlagParser flags("resample",
                   "Resamples every frame of every camera into one texture atlas of the mesh (projective texturing\n"
                   "on the GPU, visibility by shadow mapping from the camera), builds per-frame geometry and shadow\n"
                   "atlases, grows and averages them, and writes DIR/resample.json with coverage, timing and - for\n"
                   "synthetic scenes with ground_truth/ - the error against the truth per camera.");
  flags.AddPositional("SCENE", &scene_file, true, "the scene JSON file");
  flags.AddString("--out DIR", &out, "output directory (required)");
  flags.AddBool("--force", &force, kForceHelp);
  flags.AddInt("--atlas N", &o.atlas.size, "atlas resolution in texels per side");
  flags.AddInt("--gutter TEXELS", &o.atlas.gutter, "empty texels between charts");
  flags.AddDouble("--chart-angle DEGREES", &o.atlas.max_normal_deviation_deg,
                  "chart growth: max angle between a triangle's normal and its chart's, degrees");
  flags.AddInt("--grow N", &o.grow_iterations, "dilation iterations of the grown atlases");
  flags.AddDouble("--grazing-margin DEGREES", &o.resampler.grazing_margin_deg,
                  "texels seen within this angle of edge-on are invalid, degrees");
  flags.AddDouble("--depth-tolerance FRACTION", &o.resampler.relative_depth_tolerance,
                  "occlusion test: a texel is hidden when further than this fraction of its depth behind the camera's depth map");
  flags.AddDouble("--depth-tolerance-absolute DISTANCE", &o.resampler.absolute_depth_tolerance,
                  "occlusion test: and hidden only when further than this many world units (added to the relative one)");
  bool no_exact_occluders = false;
  flags.AddBool("--no-exact-occluders", &no_exact_occluders,
                "occlusion test: the depth map alone, without the exact test of the triangles seen around each texel "
                "(texels just inside another part of the mesh then pass within the tolerance)");
  flags.AddInt("--shadow-map-size N", &o.resampler.shadow_map_size, "cube shadow map resolution per face");
  flags.AddString("--save WHICH", &save, "which frames' atlases to write: first, all or none (figures cover all)");
  flags.AddBool("--no-evaluate", &no_evaluate, "skip the comparison with ground_truth/ even when present");
  flags.AddString("--egl PLATFORM", &egl, "EGL platform: auto, surfaceless (Mesa) or device (GPU)");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf resample: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  o.resampler.exact_occluder_test = !no_exact_occluders;
  auto platform = gl::ParseEglPlatform(egl);
  absl::Status usage = platform.status();
  if (usage.ok() && (o.atlas.size < 16 || o.atlas.size > 16384)) {
    usage = absl::InvalidArgumentError("--atlas: must be in [16, 16384], got " + std::to_string(o.atlas.size));
  }
  // The flags' names, not the options structs' (their checks below and in
  // the resampler guard the rest), and before any EGL set-up.
  const auto out_of_range = [&usage](const char* flag, const std::string& range, double got) {
    usage = absl::InvalidArgumentError(absl::StrCat(flag, ": must be in ", range, ", got ", got));
  };
  if (usage.ok() && (o.atlas.gutter < 0 || o.atlas.gutter > o.atlas.size / 8)) {
    out_of_range("--gutter", absl::StrCat("[0, ", o.atlas.size / 8, "] (an eighth of --atlas)"), o.atlas.gutter);
  }
  if (usage.ok() && !(o.atlas.max_normal_deviation_deg >= 1.0 && o.atlas.max_normal_deviation_deg <= 89.0)) {
    out_of_range("--chart-angle", "[1, 89] degrees", o.atlas.max_normal_deviation_deg);
  }
  if (usage.ok() && !(o.resampler.grazing_margin_deg >= 0.0 && o.resampler.grazing_margin_deg < 90.0)) {
    out_of_range("--grazing-margin", "[0, 90) degrees", o.resampler.grazing_margin_deg);
  }
  if (usage.ok() && !(o.resampler.relative_depth_tolerance >= 0.0 && std::isfinite(o.resampler.relative_depth_tolerance))) {
    out_of_range("--depth-tolerance", "[0, inf)", o.resampler.relative_depth_tolerance);
  }
  if (usage.ok() &&
      !(o.resampler.absolute_depth_tolerance >= 0.0 && std::isfinite(o.resampler.absolute_depth_tolerance))) {
    out_of_range("--depth-tolerance-absolute", "[0, inf) world units", o.resampler.absolute_depth_tolerance);
  }
  if (usage.ok() && (o.resampler.shadow_map_size < 1 || o.resampler.shadow_map_size > 8192)) {
    out_of_range("--shadow-map-size", "[1, 8192]", o.resampler.shadow_map_size);
  }
  if (usage.ok()) usage = o.atlas.Check();
  if (usage.ok() && out.empty()) usage = absl::InvalidArgumentError("--out: required");
  if (usage.ok() && o.grow_iterations < 0) usage = absl::InvalidArgumentError("--grow: must be >= 0");
  if (usage.ok() && save != "first" && save != "all" && save != "none") {
    usage = absl::InvalidArgumentError("--save: expected first, all or none, got \"" + save + "\"");
  }
  if (!usage.ok()) {
    std::fprintf(stderr, "mvbrdf resample: %s\n", std::string(usage.message()).c_str());
    return kExitUsage;
  }
  o.save = save == "all" ? pipeline::SaveFrames::kAll : save == "none" ? pipeline::SaveFrames::kNone
                                                                       : pipeline::SaveFrames::kFirst;
  o.evaluate = !no_evaluate;
  o.out_dir = out;

  // Frames are read as they are resampled; the videos are probed up front so
  // that a short or mis-sized video fails before any work.
  scene::LoadOptions load;
  load.check_all_frames = false;
  auto sequence = scene::LoadSequence(scene_file, load);
  if (!sequence.ok()) return ReportFailure(sequence.status());
  if (absl::Status s = CheckOutputDirSparesInputs("--out", out, SceneInputs(*sequence)); !s.ok()) {
    return ReportFailure(s);
  }
  absl::StatusOr<OutputDirLock> lock = PrepareOutputDir("--out", out, force);
  if (!lock.ok()) return ReportFailure(lock.status(), "mvbrdf resample");
  // An atlas that cannot fit fails now, not in an allocation minutes in.
  if (absl::Status fits = pipeline::CheckAtlasFitsInMemory(o.atlas.size, pipeline::LightLoadOf(*sequence, 0));
      !fits.ok()) {
    return ReportFailure(fits, "mvbrdf resample");
  }
  auto context = gl::EglContext::Create(*platform);
  if (!context.ok()) {
    std::fprintf(stderr, "mvbrdf resample: error: %s\n", std::string(context.status().message()).c_str());
    return kExitEnvironment;
  }
  ProgressPrinter progress(stderr);
  o.progress = [&progress](const std::string& stage, int done, int total) { progress.Update(stage, done, total); };
  auto report = pipeline::CatchOutOfMemory("resample", o.atlas.size,
                                           [&] { return pipeline::RunResampleStage(*sequence, **context, o); });
  if (!report.ok()) return ReportFailure(report.status(), "mvbrdf resample");

  const auto& a = report->atlas();
  std::printf("atlas %ux%u: %u charts, coverage %.1f%%, overlap %.4f%%, area ratio %.2f..%.2f (%s)\n", a.size(),
              a.size(), a.charts(), 100.0 * a.coverage(), 100.0 * a.overlap_fraction(), a.min_area_ratio(),
              a.max_area_ratio(), a.built() ? "built" : "mesh UVs kept");
  std::printf("%-10s %9s %9s %9s %9s\n", "camera", "valid", "recall", "false", "rmse");
  for (const v1::CameraFigures& f : report->cameras()) {
    if (report->has_ground_truth()) {
      std::printf("%-10s %8.1f%% %8.1f%% %8.2f%% %9.5f\n", f.name().c_str(), 100.0 * f.valid_fraction(),
                  100.0 * f.recall(), 100.0 * f.false_valid_fraction(), f.rmse());
    } else {
      std::printf("%-10s %8.1f%%\n", f.name().c_str(), 100.0 * f.valid_fraction());
    }
  }
  std::printf("%u frames x %d cameras in %.1f s (%.1f atlases/s on the GPU), peak memory %.0f MiB\n",
              report->frames(), report->cameras_size(), report->seconds(), report->atlases_per_second(),
              report->peak_rss_bytes() / 1048576.0);
  std::printf("wrote %s/resample.json\n", out.c_str());
  return kExitOk;
}

}  // namespace mvbrdf::client
