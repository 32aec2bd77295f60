// `mvbrdf run SCENE --out DIR`: the whole reconstruction (thesis ch. 5-7).
// The embedded default: an in-process server and worker(s) run the job as
// the service would (docs/service.md); --direct runs the library in this
// thread instead. Both write the same DIR/result.json and DIR/atlases/.
#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/bundle_upload.h"
#include "client/commands.h"
#include "client/embedded_service.h"
#include "client/flags.h"
#include "client/interrupt_cleanup.h"
#include "client/job_flags.h"
#include "client/output_dir.h"
#include "client/progress.h"
#include "client/stage_lines.h"
#include "core/base/files.h"
#include "core/base/process_stats.h"
#include "core/base/proto_json.h"
#include "core/bundle/bundle.h"
#include "core/gl/egl_context.h"
#include "core/pipeline/gather_stage.h"
#include "core/pipeline/job_options.h"
#include "core/pipeline/memory_estimate.h"
#include "core/pipeline/reconstruct_stage.h"
#include "core/pipeline/run_scene.h"
#include "core/scene/names.h"
#include "core/scene/sequence.h"

namespace mvbrdf::client {
namespace {

namespace fs = std::filesystem;

void PrintReport(const v1::RunReport& report, const std::string& out) {
  // Issue #14: the camera refinement before pass 1 (docs/glossary.md "calibration").
  if (report.has_calibration()) {
    const v1::CalibrationReport& c = report.calibration();
    std::printf("\ncameras: %s (--refine-cameras %s): %s\n", c.cameras_refined() ? "refined" : "not refined",
                c.cameras_mode().c_str(), scene::ShownName(c.cameras_decision()).c_str());
    if (c.cameras_refined()) {
      double rotation = 0.0, reprojection = 0.0;
      for (const v1::CameraRefinementRow& r : c.cameras()) {
        rotation = std::max(rotation, r.rotation_change_deg());
        reprojection = std::max(reprojection, r.reprojection_change_px());
      }
      std::printf("  %d cameras, largest rotation change %.4f deg, reprojection change %.3f px\n", c.cameras_size(),
                  rotation, reprojection);
    }
  }
  if (report.light_configurations_size() > 0) {
    std::printf("\n%-32s %9s %11s %11s %11s %8s\n", "configuration", "triangles", "E_a", "E_d", "held-out", "seconds");
    for (const auto& r : report.light_configurations()) {
      std::printf("%-32s %9u %11.6f %11.6f %11.6f %8.2f%s\n", r.name().c_str(), r.lit_triangles(), r.e_a(), r.e_d(),
                  r.e_held_out(), r.seconds(), r.name() == report.chosen_configuration() ? "  <- chosen" : "");
    }
  }
  std::printf("\nconfiguration: %s", report.chosen_configuration().c_str());
  if (report.light_configurations_size() > 1) {
    std::printf(" (the next best %s is %.1f %% higher)",
                report.configuration_criterion() == "held-out" ? "held-out error" : "E_d",
                100.0 * report.configuration_margin());
  }
  std::printf("\n");
  if (!report.configuration_warning().empty()) std::printf("warning: %s\n", report.configuration_warning().c_str());
  if (report.solvers_size() > 0) {
    std::printf("\n%-10s %-20s %-26s %-26s %-26s %12s %8s\n", "cluster", "solver", "kd (RGB)", "ks (RGB)", "ke (RGB)",
                "cost", "seconds");
    for (const auto& s : report.solvers()) {
      std::printf("%-10s %-20s %8.4f %8.4f %8.4f %8.4f %8.4f %8.4f %8.2f %8.2f %8.2f %12.6g %8.3f\n",
                  s.cluster().c_str(), s.solver().c_str(), s.kd(0), s.kd(1), s.kd(2), s.ks(0), s.ks(1), s.ks(2),
                  s.ke(0), s.ke(1), s.ke(2), s.final_cost(), s.seconds());
    }
  }
  if (report.clusters_size() > 0) {
    // Every cluster with its texels; one that is not a material (flags
    // "tiny": merged into the nearest; "no_samples") is marked, not a row of
    // fitted numbers (docs/glossary.md "cluster").
    std::printf("\n%-10s %8s %-26s %s\n", "cluster", "texels", "centre (linear RGB)", "flags");
    for (const auto& c : report.clusters()) {
      std::string centre;
      for (double v : c.centre()) {
        char value[32];
        std::snprintf(value, sizeof value, "%8.4f ", v);
        centre += value;
      }
      const std::string flags = absl::StrJoin(c.flags(), ", ");
      std::printf("%-10s %8llu %-26s %s\n", c.name().c_str(), static_cast<unsigned long long>(c.texels()),
                  centre.c_str(), flags.empty() ? "-" : flags.c_str());
    }
  }
  if (report.cameras_size() > 0) {
    std::printf("\n%-10s %12s %16s\n", "camera", "BRDF atlas", "correction atlas");
    for (const auto& c : report.cameras()) {
      if (c.has_mse_brdf()) {
        std::printf("%-10s %12.6f %16.6f\n", c.name().c_str(), c.mse_brdf(), c.mse_correction());
      } else {
        std::printf("%-10s %12s %16s\n", c.name().c_str(), "absent", "absent");
      }
    }
  }
  for (const std::string& w : report.warnings()) std::printf("warning: %s\n", w.c_str());
  // Video.mask_path and saturation_level (per camera in result.json's cameras).
  std::printf("\nrefused texel observations: %llu outside a camera's mask, %llu saturated\n",
              static_cast<unsigned long long>(report.masked_observations()),
              static_cast<unsigned long long>(report.saturated_observations()));
  std::printf("\n%u frames in %.1f s, peak memory %.0f MiB; wrote %s/result.json\n", report.frames(), report.seconds(),
              report.peak_rss_bytes() / 1048576.0, out.c_str());
}

// Removes a temporary directory on every path out.
class TempDir {
 public:
  explicit TempDir(fs::path path) : path_(std::move(path)) {}
  ~TempDir() {
    std::error_code ec;
    if (!path_.empty()) fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

int RunDirect(const scene::Sequence& sequence, const v1::SubmitJobRequest& request, gl::EglPlatform platform,
              int threads, const std::string& out, const std::vector<std::string>& command_line) {
  absl::StatusOr<pipeline::ReconstructOptions> o = pipeline::ReconstructOptionsFor(request, threads);
  if (!o.ok()) return ReportFailure(o.status(), "mvbrdf run");
  o->out_dir = out;
  for (const std::string& arg : command_line) o->run_options.add_command_line(arg);
  o->run_options.set_direct(true);
  auto context = gl::EglContext::Create(platform);
  if (!context.ok()) return ReportFailure(context.status(), "mvbrdf run");
  // One line per finished stage, with result.json's seconds for it.
  ProgressPrinter progress(stderr, /*timed_done_lines=*/false);
  o->progress = [&progress](const std::string& stage, int done, int total) { progress.Update(stage, done, total); };
  o->stage_done = [&progress](const v1::StageRow& row) { progress.StageDone(row.name(), row.seconds()); };
  auto report = pipeline::CatchOutOfMemory("run", o->atlas.size,
                                           [&] { return pipeline::RunReconstruction(sequence, **context, *o); });
  if (!report.ok()) return ReportFailure(report.status(), "mvbrdf run");
  PrintReport(*report, out);
  return kExitOk;
}

// Follows the job's events to its end; progress on stderr. Returns the final state.
absl::StatusOr<v1::JobState> FollowJob(v1::Mvbrdf::Stub& stub, const std::string& job_id, std::string* error) {
  grpc::ClientContext context;
  v1::WatchJobRequest request;
  request.set_job_id(job_id);
  std::unique_ptr<grpc::ClientReader<v1::JobEvent>> reader = stub.WatchJob(&context, request);
  ProgressPrinter progress(stderr, /*timed_done_lines=*/false);
  v1::JobEvent event;
  v1::JobState state = v1::QUEUED;
  while (reader->Read(&event)) {
    if (event.has_stage_finished()) {
      // One line per finished task (as `watch` shows it); the stages' own
      // lines follow from result.json when the job is done.
      for (const std::string& line : StageFinishedLines(event.stage_finished())) progress.Line(line);
    } else if (event.has_progress()) {
      progress.Update(event.progress().stage(), static_cast<int>(event.progress().fraction() * 100.0 + 0.5), 100);
    } else if (event.has_state()) {
      state = event.state();
    } else if (event.has_failed()) {
      *error = event.failed();
    }
    // The server ends the stream after the final state (and the reason
    // after FAILED), so reading on to the end gets both.
  }
  const grpc::Status finished = reader->Finish();
  if (state != v1::SUCCEEDED && state != v1::FAILED && state != v1::CANCELLED && !finished.ok()) {
    return absl::Status(static_cast<absl::StatusCode>(finished.error_code()),
                        absl::StrCat("watching the job: ", finished.error_message()));
  }
  return state;
}

int RunEmbedded(const std::string& scene_file, const v1::SubmitJobRequest& base, gl::EglPlatform platform, int threads,
                int workers, const std::string& data_flag, const std::string& out, InterruptCleanup* cleanup,
                const std::vector<std::string>& command_line) {
  const auto start = std::chrono::steady_clock::now();
  // The server's state: --data keeps it (and its Sample cache) across runs.
  fs::path data_dir = data_flag;
  std::unique_ptr<TempDir> temp;
  if (data_dir.empty()) {
    const absl::StatusOr<fs::path> tmp = TemporaryDirectory();
    if (!tmp.ok()) return ReportFailure(tmp.status(), "mvbrdf run");
    std::string temp_template = (*tmp / "mvbrdf-run-XXXXXX").string();
    if (mkdtemp(temp_template.data()) == nullptr) {
      return ReportFailure(absl::UnavailableError("cannot create a temporary directory in " + tmp->string()),
                           "mvbrdf run");
    }
    data_dir = temp_template;
    temp = std::make_unique<TempDir>(data_dir);
    cleanup->Remove(data_dir);  // also on SIGINT and SIGTERM
  }
  EmbeddedOptions eo;
  eo.data_dir = data_dir;
  eo.workers = workers;
  eo.egl = platform;
  eo.threads_per_worker = threads;
  if (std::getenv("MVBRDF_VERBOSE") != nullptr) {
    eo.log = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  }
  auto service = EmbeddedService::Start(eo);
  if (!service.ok()) return ReportFailure(service.status(), "mvbrdf run");
  auto stub = v1::Mvbrdf::NewStub((*service)->channel());

  v1::SubmitJobRequest request = base;
  const fs::path archive = data_dir / "run-bundle.tar";
  {
    absl::StatusOr<bundle::BundleInfo> info = bundle::PackBundle(scene_file, archive);
    if (!info.ok()) return ReportFailure(info.status(), "mvbrdf run");
    // The server is in this process: the packed file becomes its bundle as
    // it is (no upload copying and hashing it again), else it is uploaded.
    absl::Status uploaded = (*service)->AdoptBundle(archive, info->sha256);
    if (!uploaded.ok()) {
      UploadOutcome outcome;
      uploaded = UploadBundleFile(*stub, "run", archive, info->sha256, static_cast<uint64_t>(info->size), nullptr,
                                  &outcome);
    }
    std::error_code ec;
    fs::remove(archive, ec);
    if (!uploaded.ok()) return ReportFailure(uploaded, "mvbrdf run");
    request.set_bundle_sha256(info->sha256);
    request.set_scene_path(fs::path(scene_file).filename().string());
  }
  v1::SubmitJobResponse submitted;
  {
    grpc::ClientContext context;
    context.AddMetadata("x-mvbrdf-client", "run");
    const grpc::Status status = stub->SubmitJob(&context, request, &submitted);
    if (!status.ok()) {
      std::fprintf(stderr, "mvbrdf run: error: %s\n", scene::ShownName(status.error_message()).c_str());
      return ExitCodeForRpc(status.error_code());
    }
  }
  std::string error;
  absl::StatusOr<v1::JobState> state = FollowJob(*stub, submitted.job().id(), &error);
  if (!state.ok()) return ReportFailure(state.status(), "mvbrdf run");
  if (*state != v1::SUCCEEDED) {
    std::fprintf(stderr, "mvbrdf run: error: %s\n",
                 error.empty() ? "the job did not succeed" : scene::ShownName(error).c_str());
    return *state == v1::CANCELLED ? kExitJobCancelled : kExitJobFailed;
  }
  absl::StatusOr<std::vector<std::string>> copied = (*service)->CopyArtifacts(submitted.job().id(), out);
  if (!copied.ok()) return ReportFailure(copied.status(), "mvbrdf run");
  // result.json as a one-process run writes it: the user's scene file
  // (relative to DIR, not the in-process server's bundle), the command line,
  // the whole run's time and memory.
  v1::RunReport report;
  if (absl::Status s = ReadJsonFile(fs::path(out) / "result.json", &report); !s.ok()) {
    return ReportFailure(s, "mvbrdf run");
  }
  {
    // The stages as result.json has them (a one-process run prints these as
    // they finish).
    ProgressPrinter stages(stderr, /*timed_done_lines=*/false);
    for (const v1::StageRow& row : report.stages()) stages.StageDone(row.name(), row.seconds());
  }
  report.set_scene(pipeline::SceneRelativeTo(scene_file, out));
  report.clear_bundle_sha256();
  for (const std::string& arg : command_line) report.mutable_options()->add_command_line(arg);
  report.set_seconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  report.set_peak_rss_bytes(PeakRssBytes());
  if (absl::Status s = WriteJsonFile(fs::path(out) / "result.json", report); !s.ok()) {
    return ReportFailure(s, "mvbrdf run");
  }
  PrintReport(report, out);
  return kExitOk;
}

}  // namespace

int RunRun(const std::vector<std::string>& args) {
  // Before any thread starts (OpenCV's, gRPC's): see InterruptCleanup.
  InterruptCleanup cleanup;
  std::string scene_file, out, egl = "auto", data_dir, export_file;
  JobFlags job;
  int threads = 2, workers = 1;
  bool direct = false, write_report = false, force = false;
  ReportFlags report_flags;
  FlagParser flags("run",
                   "Reconstructs a spatially varying Phong BRDF from the scene: resamples every frame into the\n"
                   "texture atlas, sweeps the candidate light configurations (Table 6.1), clusters texels into\n"
                   "materials and fits one BRDF per cluster (Table 6.2), solves kd per texel, writes kd/ks/ke,\n"
                   "cluster, confidence and per-frame correction atlases and the per-camera errors (Table 7.1)\n"
                   "to DIR/result.json and DIR/atlases/. Only the stages the scene and --outputs need run; the\n"
                   "plan says which were skipped and why. Runs as the service would, on an in-process server\n"
                   "and --workers workers (no set-up); --direct runs the pipeline in one thread instead.");
  flags.AddPositional("SCENE", &scene_file, true, "the scene JSON file");
  flags.AddString("--out DIR", &out, "output directory (required)");
  flags.AddBool("--force", &force, kForceHelp);
  AddJobFlags(flags, &job);
  flags.AddInt("--threads N", &threads, "threads per worker (light sweep)");
  flags.AddInt("--workers N", &workers, "in-process workers, each with its own EGL context");
  flags.AddString("--data DIR", &data_dir, "keep the in-process server's state (and Sample cache) here (default: temporary)");
  flags.AddBool("--direct", &direct, "run the pipeline directly, without the in-process service");
  flags.AddString("--egl PLATFORM", &egl, "EGL platform: auto, surfaceless (Mesa) or device (GPU)");
  flags.AddBool("--report", &write_report, "also write DIR/report.html (see 'mvbrdf report')");
  flags.AddString("--export FILE", &export_file,
                  "also write the reconstruction as glTF 2.0 to FILE (.glb or .gltf; see 'mvbrdf export')");
  AddReportFlags(flags, &report_flags);
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf run: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  v1::SubmitJobRequest request;
  absl::Status usage = ToSubmitRequest(job, &request);
  auto platform = gl::ParseEglPlatform(egl);
  if (usage.ok()) usage = platform.status();
  if (usage.ok() && out.empty()) usage = absl::InvalidArgumentError("--out: required");
  if (usage.ok() && !export_file.empty()) usage = CheckExportFile("--export", export_file);
  if (usage.ok() && (threads < 1 || threads > 64)) usage = absl::InvalidArgumentError("--threads: must be in [1, 64]");
  if (usage.ok() && (workers < 1 || workers > 16)) usage = absl::InvalidArgumentError("--workers: must be in [1, 16]");
  // As `report` checks it (99999999 made run --report render for hours; -5 was taken).
  if (usage.ok() && (report_flags.relit_frames < 0 || report_flags.relit_frames > 360)) {
    usage = absl::InvalidArgumentError(
        absl::StrCat("--relit-frames: must be in [0, 360], got ", report_flags.relit_frames));
  }
  if (!usage.ok()) {
    std::fprintf(stderr, "mvbrdf run: %s\n", std::string(usage.message()).c_str());
    return kExitUsage;
  }

  // Absolute for the in-process server; result.json names it relative to
  // --out (pipeline::SceneRelativeTo).
  std::error_code absolute_error;
  const std::filesystem::path absolute_scene = std::filesystem::absolute(scene_file, absolute_error);
  if (!absolute_error) scene_file = absolute_scene.lexically_normal().string();
  scene::LoadOptions load;
  load.check_all_frames = false;  // each frame is checked when it is read
  auto sequence = scene::LoadSequence(scene_file, load);
  if (!sequence.ok()) return ReportFailure(sequence.status());
  if (absl::Status s = CheckOutputDirSparesInputs("--out", out, SceneInputs(*sequence)); !s.ok()) {
    return ReportFailure(s);
  }
  if (!data_dir.empty() && !direct) {
    // The server's state (state.db, artifacts/, bundles/, ...) is written
    // there: neither among the scene's inputs nor mixed with --out's files.
    std::vector<InputPath> kept = SceneInputs(*sequence);
    kept.push_back({"--out", std::filesystem::path(out) / "result.json", false});
    if (absl::Status s = CheckOutputDirSparesInputs("--data", data_dir, kept); !s.ok()) return ReportFailure(s);
    if (absl::Status s = CheckOutputDirSparesInputs(
            "--out", out, {{"--data (the server's state)", std::filesystem::path(data_dir) / "state.db", false}});
        !s.ok()) {
      return ReportFailure(s);
    }
  }
  auto options = pipeline::ReconstructOptionsFor(request, threads);
  if (!options.ok()) return ReportFailure(options.status());
  auto plan = pipeline::MakePlan(*sequence, options->request);
  if (!plan.ok()) return ReportFailure(plan.status());
  // One command at a time writes DIR (held to the end, the report included).
  absl::StatusOr<OutputDirLock> lock = PrepareOutputDir("--out", out, force);
  if (!lock.ok()) return ReportFailure(lock.status(), "mvbrdf run");
  if (absl::Status footprint = pipeline::CheckPixelFootprint(options->pixel_footprint, sequence->lights.size());
      !footprint.ok()) {
    return ReportFailure(footprint, "mvbrdf run");
  }
  // Direct or through the in-process workers, the atlas is allocated here.
  const int reservoir_slots =
      plan->Has(pipeline::Stage::kTexelPass) ? options->reservoir_uniform + options->reservoir_highlight : 0;
  if (absl::Status fits =
          pipeline::CheckAtlasFitsInMemory(options->atlas.size, pipeline::LightLoadOf(*sequence, reservoir_slots,
                                                                                    options->pixel_footprint));
      !fits.ok()) {
    return ReportFailure(fits, "mvbrdf run");
  }
  // A previous run's result.json goes first, so that an interrupted or failed
  // run leaves no result.json beside a mix of new and old atlases (render and
  // evaluate read it as a whole run); the new one is written last.
  std::error_code stale_error;
  std::filesystem::remove(std::filesystem::path(out) / "result.json", stale_error);
  if (stale_error) {
    return ReportFailure(ErrnoStatus(stale_error.value(), "cannot remove the previous run's result.json",
                                     (std::filesystem::path(out) / "result.json").string()),
                         "mvbrdf run");
  }
  std::fputs(plan->Describe().c_str(), stdout);
  std::fflush(stdout);
  std::vector<std::string> command_line = {"mvbrdf", "run"};
  command_line.insert(command_line.end(), args.begin(), args.end());
  const int ran = direct ? RunDirect(*sequence, request, *platform, threads, out, command_line)
                         : RunEmbedded(scene_file, request, *platform, threads, workers, data_dir, out, &cleanup,
                                       command_line);
  if (ran != kExitOk) return ran;
  if (!export_file.empty()) {
    if (absl::Status s = ExportRun(out, *sequence, export_file, -1); !s.ok()) return ReportFailure(s, "mvbrdf run");
  }
  if (!write_report) return kExitOk;
  report_flags.egl = egl;
  const std::filesystem::path report_file = std::filesystem::path(out) / "report.html";
  if (absl::Status s = WriteRunReport(out, report_file, report_flags); !s.ok()) return ReportFailure(s, "mvbrdf run");
  std::printf("wrote %s\n", report_file.string().c_str());
  return kExitOk;
}

}  // namespace mvbrdf::client
