// `mvbrdf run SCENE --out DIR`: the whole reconstruction (thesis ch. 5-7).
#include <cstdio>

#include "absl/strings/str_split.h"
#include "client/commands.h"
#include "client/flags.h"
#include "client/progress.h"
#include "core/gl/egl_context.h"
#include "core/pipeline/reconstruct_stage.h"
#include "core/scene/sequence.h"

namespace mvbrdf::client {

int RunRun(const std::vector<std::string>& args) {
  std::string scene_file, out, egl = "auto", outputs = "light,brdf,correction,errors";
  pipeline::ReconstructOptions o;
  bool no_powell = false;
  int cluster_samples = static_cast<int>(o.max_cluster_samples);
  FlagParser flags("run",
                   "Reconstructs a spatially varying Phong BRDF from the scene: resamples every frame into the\n"
                   "texture atlas, sweeps the candidate light configurations (Table 6.1), clusters texels into\n"
                   "materials and fits one BRDF per cluster (Table 6.2), solves kd per texel, writes kd/ks/ke,\n"
                   "cluster, confidence and per-frame correction atlases and the per-camera errors (Table 7.1)\n"
                   "to DIR/result.json and DIR/atlases/. Only the stages the scene and --outputs need run; the\n"
                   "plan says which were skipped and why.");
  flags.AddPositional("SCENE", &scene_file, true, "the scene JSON file");
  flags.AddString("--out", &out, "output directory (required)");
  flags.AddString("--outputs", &outputs, "comma-separated: light (Table 6.1), brdf (atlases), correction, errors");
  flags.AddString("--config", &o.request.configuration, "a known light configuration: skips the sweep");
  flags.AddBool("--no-powell", &no_powell, "skip the Powell comparison (Table 6.2)");
  flags.AddInt("--atlas", &o.atlas.size, "atlas resolution in texels per side");
  flags.AddInt("--cluster-samples", &cluster_samples, "Samples per cluster fit, at most");
  flags.AddInt("--sweep-frame-stride", &o.sweep_frame_stride, "use every n-th frame for the light sweep");
  flags.AddInt("--max-iterations", &o.fit.max_iterations, "iterations of each BRDF fit, at most");
  flags.AddInt("--grow", &o.grow_iterations, "dilation iterations of the written atlases");
  flags.AddInt("--threads", &o.threads, "threads for the light sweep");
  flags.AddString("--egl", &egl, "EGL platform: auto, surfaceless (Mesa) or device (GPU)");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf run: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  o.request.light_table = o.request.brdf_atlases = o.request.correction = o.request.camera_errors = false;
  absl::Status usage = absl::OkStatus();
  for (absl::string_view part : absl::StrSplit(outputs, ',', absl::SkipEmpty())) {
    if (part == "light") o.request.light_table = true;
    else if (part == "brdf") o.request.brdf_atlases = true;
    else if (part == "correction") o.request.correction = true;
    else if (part == "errors") o.request.camera_errors = true;
    else usage = absl::InvalidArgumentError("--outputs: expected light, brdf, correction or errors, got \"" +
                                            std::string(part) + "\"");
  }
  o.request.compare_solvers = !no_powell;
  auto platform = gl::ParseEglPlatform(egl);
  if (usage.ok()) usage = platform.status();
  if (usage.ok() && out.empty()) usage = absl::InvalidArgumentError("--out: required");
  if (usage.ok() && (o.atlas.size < 16 || o.atlas.size > 16384)) {
    usage = absl::InvalidArgumentError("--atlas: must be in [16, 16384], got " + std::to_string(o.atlas.size));
  }
  if (usage.ok() && cluster_samples < 10) usage = absl::InvalidArgumentError("--cluster-samples: must be >= 10");
  if (usage.ok() && o.sweep_frame_stride < 1) usage = absl::InvalidArgumentError("--sweep-frame-stride: must be >= 1");
  if (usage.ok() && (o.threads < 1 || o.threads > 64)) usage = absl::InvalidArgumentError("--threads: must be in [1, 64]");
  if (usage.ok()) usage = o.fit.Check();
  if (!usage.ok()) {
    std::fprintf(stderr, "mvbrdf run: %s\n", std::string(usage.message()).c_str());
    return kExitUsage;
  }
  o.max_cluster_samples = static_cast<size_t>(cluster_samples);
  o.out_dir = out;

  scene::LoadOptions load;
  load.check_all_frames = false;  // each frame is checked when it is read
  auto sequence = scene::LoadSequence(scene_file, load);
  if (!sequence.ok()) return ReportFailure(sequence.status());
  auto plan = pipeline::MakePlan(*sequence, o.request);
  if (!plan.ok()) return ReportFailure(plan.status());
  std::fputs(plan->Describe().c_str(), stdout);
  auto context = gl::EglContext::Create(*platform);
  if (!context.ok()) {
    std::fprintf(stderr, "mvbrdf run: error: %s\n", std::string(context.status().message()).c_str());
    return kExitEnvironment;
  }
  ProgressPrinter progress(stderr);
  o.progress = [&progress](const std::string& stage, int done, int total) { progress.Update(stage, done, total); };
  auto report = pipeline::RunReconstruction(*sequence, **context, o);
  if (!report.ok()) return ReportFailure(report.status());

  if (report->light_configurations_size() > 0) {
    std::printf("\n%-32s %9s %11s %11s %8s\n", "configuration", "triangles", "E_a", "E_d", "seconds");
    for (const auto& r : report->light_configurations()) {
      std::printf("%-32s %9u %11.6f %11.6f %8.2f%s\n", r.name().c_str(), r.lit_triangles(), r.e_a(), r.e_d(),
                  r.seconds(), r.name() == report->chosen_configuration() ? "  <- chosen" : "");
    }
  }
  std::printf("\nconfiguration: %s", report->chosen_configuration().c_str());
  if (report->light_configurations_size() > 1) {
    std::printf(" (the next best E_d is %.1f %% higher)", 100.0 * report->configuration_margin());
  }
  std::printf("\n");
  if (!report->configuration_warning().empty()) {
    std::printf("warning: %s\n", report->configuration_warning().c_str());
  }
  if (report->solvers_size() > 0) {
    std::printf("\n%-10s %-20s %-26s %-26s %-26s %12s %8s\n", "cluster", "solver", "kd (RGB)", "ks (RGB)", "ke (RGB)",
                "cost", "seconds");
    for (const auto& s : report->solvers()) {
      std::printf("%-10s %-20s %8.4f %8.4f %8.4f %8.4f %8.4f %8.4f %8.2f %8.2f %8.2f %12.6g %8.3f\n",
                  s.cluster().c_str(), s.solver().c_str(), s.kd(0), s.kd(1), s.kd(2), s.ks(0), s.ks(1), s.ks(2),
                  s.ke(0), s.ke(1), s.ke(2), s.final_cost(), s.seconds());
    }
  }
  if (report->cameras_size() > 0) {
    std::printf("\n%-10s %12s %16s\n", "camera", "BRDF atlas", "correction atlas");
    for (const auto& c : report->cameras()) {
      std::printf("%-10s %12.6f %16.6f\n", c.name().c_str(), c.mse_brdf(), c.mse_correction());
    }
  }
  std::printf("\n%u frames in %.1f s, peak memory %.0f MiB; wrote %s/result.json\n", report->frames(),
              report->seconds(), report->peak_rss_bytes() / 1048576.0, out.c_str());
  return kExitOk;
}

}  // namespace mvbrdf::client
