#include "worker/task_runner.h"

#include <algorithm>
#include <chrono>
#include <system_error>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/process_stats.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/bundle/sha256.h"
#include "core/fit/light_sweep.h"
#include "core/pipeline/calibration_stage.h"
#include "core/pipeline/gather_stage.h"
#include "core/pipeline/job_options.h"
#include "core/pipeline/light_table.h"
#include "core/pipeline/memory_estimate.h"
#include "core/pipeline/plan.h"
#include "core/pipeline/reconstruct_stage.h"
#include "core/pipeline/refine_lights_stage.h"
#include "core/report/report_inputs.h"
#include "core/samples/assemble.h"
#include "worker/worker_fault.h"

namespace mvbrdf::worker {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double Since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

absl::StatusOr<pipeline::ReconstructOptions> OptionsOf(const v1::Task& task, const TaskEnvironment& env) {
  MVBRDF_ASSIGN_OR_RETURN(pipeline::ReconstructOptions o, pipeline::ReconstructOptionsFor(task.request(), env.threads));
  o.progress = env.progress;
  o.cancelled = env.cancelled;
  // result.json names the scene inside the bundle, never the worker's cache.
  o.bundle_sha256 = task.bundle_sha256();
  o.scene_in_bundle = task.request().scene_path().empty() ? "scene.json" : task.request().scene_path();
  return o;
}

// Every regular file under `dir`, as (relative name, path), sorted by name.
std::vector<std::pair<std::string, fs::path>> FilesUnder(const fs::path& dir) {
  std::vector<std::pair<std::string, fs::path>> files;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file()) files.emplace_back(fs::relative(e.path(), dir).generic_string(), e.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// DIR/report.html from the outputs just written to DIR (env.scratch_dir), as
// `mvbrdf report DIR` makes it: a service artifact like the others. `gl`: the
// context of a GL task (renderings), null on a CPU task's thread.
absl::Status WriteReportHtml(const TaskEnvironment& env, const scene::Sequence& sequence, gl::EglContext* gl) {
  report::ReportOptions options;
  options.gl = gl;
  // result.json names the scene inside the bundle (RunReport.bundle_sha256);
  // here it is the unpacked bundle's file.
  options.scene = sequence.scene_file;
  options.scratch_dir = env.scratch_dir.string() + ".report";  // beside: not an artifact
  std::error_code ec;
  fs::create_directories(options.scratch_dir, ec);
  absl::StatusOr<report::ReportInputs> inputs = report::CollectReportInputs(env.scratch_dir, options);
  fs::remove_all(options.scratch_dir, ec);
  if (!inputs.ok()) {
    return absl::Status(inputs.status().code(), absl::StrCat("report.html: ", inputs.status().message()));
  }
  return WriteStringToFile(env.scratch_dir / "report.html", report::BuildReportHtml(*inputs));
}

absl::StatusOr<TaskOutput> Gather(const v1::Task& task, const scene::Sequence& sequence, const TaskEnvironment& env) {
  MVBRDF_ASSIGN_OR_RETURN(const pipeline::ReconstructOptions o, OptionsOf(task, env));
  MVBRDF_ASSIGN_OR_RETURN(const pipeline::Plan plan, pipeline::MakePlan(sequence, o.request));
  const bool texels = env.gather_texel_statistics && plan.Has(pipeline::Stage::kTexelPass);
  // Camera refinement before resampling (issue #14): the Samples, and every
  // later task of the job (GatherResult.calibration), use these cameras.
  MVBRDF_ASSIGN_OR_RETURN(v1::CalibrationReport calibration, pipeline::RefineCamerasStage(sequence, *env.gl, plan, o));
  MVBRDF_ASSIGN_OR_RETURN(const std::optional<scene::Sequence> calibrated,
                          pipeline::CalibratedSequence(sequence, calibration));
  const scene::Sequence& used = calibrated.has_value() ? *calibrated : sequence;
  const auto gather_start = Clock::now();
  MVBRDF_ASSIGN_OR_RETURN(const atlas::Atlas atlas, atlas::BuildAtlas(used.topology, used.rest_positions, o.atlas));
  MVBRDF_ASSIGN_OR_RETURN(pipeline::Gathered gathered, pipeline::GatherPass(used, *env.gl, atlas, o, true, texels));
  samples::SampleSet& set = gathered.triangle_samples;
  TaskOutput out;
  out.samples = samples::EncodeSampleSet(set, /*compact=*/false);
  v1::GatherResult result;
  result.set_samples(set.size());
  result.set_encoded_bytes(out.samples.size());
  // Pass 1's time; the refinement's is calibration.cameras_seconds.
  result.set_seconds(Since(gather_start));
  *result.mutable_calibration() = std::move(calibration);
  result.set_samples_sha256(bundle::Sha256Bytes(out.samples));
  result.set_texel_statistics(texels);
  result.set_peak_rss_bytes(PeakRssBytes());
  result.SerializeToString(&out.result);
  out.metrics["samples"] = static_cast<double>(set.size());
  out.sample_set = std::make_shared<const samples::SampleSet>(std::move(set));
  out.texel_statistics = std::move(gathered.texels);
  return out;
}

absl::StatusOr<TaskOutput> Sweep(const v1::Task& task, const scene::Sequence& sequence, const TaskEnvironment& env) {
  MVBRDF_ASSIGN_OR_RETURN(const pipeline::ReconstructOptions o, OptionsOf(task, env));
  if (task.inputs_size() != 1 || task.inputs(0).kind() != "gather") {
    return absl::InvalidArgumentError("inputs: a sweep task depends on exactly one gather task");
  }
  v1::GatherResult gathered;
  if (!gathered.ParseFromString(task.inputs(0).result())) {
    return absl::InvalidArgumentError("inputs[0].result: not a GatherResult");
  }
  const v1::LightConfiguration* config = nullptr;
  for (const v1::LightConfiguration& c : sequence.scene.light_configurations()) {
    if (c.name() == task.key()) config = &c;
  }
  if (config == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat("key: the scene has no light configuration \"", task.key(), "\""));
  }
  if (!env.samples) return absl::FailedPreconditionError("sweep: this worker cannot fetch Samples");
  MVBRDF_ASSIGN_OR_RETURN(const std::shared_ptr<const samples::SampleSet> set, env.samples(gathered));
  MVBRDF_ASSIGN_OR_RETURN(
      const fit::SweepResult sweep,
      fit::SweepConfigurations(*set, sequence.topology.triangles.size(),
                               {{config->name(), {config->lights().begin(), config->lights().end()}}}, o.fit, o.diffuse,
                               env.threads, o.sweep_fit_samples, samples::OwnLightingFrames(sequence)));
  v1::LightConfigurationRow row;
  pipeline::SweepRowToProto(sweep.rows.at(0), &row);
  TaskOutput out;
  row.SerializeToString(&out.result);
  out.metrics["E_a"] = row.e_a();
  out.metrics["E_d"] = row.e_d();
  out.metrics["held_out"] = row.e_held_out();
  out.samples_from_cache = gathered.from_cache();
  return out;
}

absl::StatusOr<TaskOutput> Choose(const v1::Task& task, const scene::Sequence& sequence, const TaskEnvironment& env) {
  MVBRDF_ASSIGN_OR_RETURN(const pipeline::ReconstructOptions o, OptionsOf(task, env));
  MVBRDF_ASSIGN_OR_RETURN(v1::RunReport report,
                          pipeline::NewRunReport(sequence, o, env.gl != nullptr ? env.gl->Describe() : ""));
  MVBRDF_ASSIGN_OR_RETURN(const pipeline::Plan plan, pipeline::MakePlan(sequence, o.request));
  // The sweep's wall time: from the first sweep task's start to the last
  // one's end, whichever workers ran them (the sum of the rows' seconds when
  // the inputs carry no times).
  double sum = 0.0;
  int64_t first_start = 0, last_end = 0;
  for (int i = 0; i < task.inputs_size(); ++i) {
    const v1::TaskInput& input = task.inputs(i);
    if (input.kind() == "gather") {
      // Pass 1's time, as a one-process run reports it: "gather_samples"
      // when the pass gathered the texel statistics too, else the light
      // Samples only (the reflectance task then reports its own pass).
      v1::GatherResult gathered;
      if (!gathered.ParseFromString(input.result())) {
        return absl::InvalidArgumentError(absl::StrCat("inputs[", i, "].result: not a GatherResult"));
      }
      // The gather's camera refinement (issue #14): in the report, and on to
      // the reflectance task with the light table.
      *report.mutable_calibration() = gathered.calibration();
      if (plan.Has(pipeline::Stage::kRefineCameras)) {
        v1::StageRow* refine = report.add_stages();
        refine->set_name("refine_cameras");
        refine->set_seconds(gathered.calibration().cameras_seconds());
        refine->set_peak_rss_bytes(gathered.peak_rss_bytes());
      }
      v1::StageRow* stage = report.add_stages();
      stage->set_name(gathered.texel_statistics() || !plan.Has(pipeline::Stage::kTexelPass) ? "gather_samples"
                                                                                              : "gather_light_samples");
      stage->set_seconds(gathered.seconds());
      stage->set_peak_rss_bytes(gathered.peak_rss_bytes());
      continue;
    }
    v1::LightConfigurationRow* row = report.add_light_configurations();
    if (input.kind() != "sweep" || !row->ParseFromString(input.result())) {
      return absl::InvalidArgumentError(absl::StrCat("inputs[", i, "]: expected a sweep task's row"));
    }
    sum += row->seconds();
    if (input.started_unix_ms() > 0 && (first_start == 0 || input.started_unix_ms() < first_start)) {
      first_start = input.started_unix_ms();
    }
    last_end = std::max(last_end, input.finished_unix_ms());
  }
  MVBRDF_RETURN_IF_ERROR(pipeline::ChooseConfiguration(&report));
  MVBRDF_RETURN_IF_ERROR(pipeline::CheckMetricsFinite(report));
  v1::StageRow* stage = report.add_stages();
  stage->set_name("light_sweep");
  stage->set_peak_rss_bytes(PeakRssBytes());
  stage->set_seconds(first_start > 0 && last_end >= first_start ? (last_end - first_start) / 1000.0 : sum);
  if (plan.Has(pipeline::Stage::kRefineLights)) {
    // On the gather task's triangle Samples, as a one-process run refines them.
    if (!env.samples) return absl::FailedPreconditionError("choose: this worker cannot fetch Samples");
    for (const v1::TaskInput& input : task.inputs()) {
      v1::GatherResult gathered;
      if (input.kind() != "gather" || !gathered.ParseFromString(input.result())) continue;
      MVBRDF_ASSIGN_OR_RETURN(const std::shared_ptr<const samples::SampleSet> set, env.samples(gathered));
      // With the cameras as the gather refined them, as a one-process run.
      MVBRDF_ASSIGN_OR_RETURN(const std::optional<scene::Sequence> calibrated,
                              pipeline::CalibratedSequence(sequence, gathered.calibration()));
      MVBRDF_RETURN_IF_ERROR(
          pipeline::RefineLightsStage(calibrated.has_value() ? *calibrated : sequence, *set, o, &report));
      break;
    }
  }
  TaskOutput out;
  out.metrics["configurations"] = report.light_configurations_size();
  out.metrics["configuration_margin"] = report.configuration_margin();
  if (!plan.Has(pipeline::Stage::kTexelPass)) {
    // The job ends here: its result.json.
    const fs::path file = env.scratch_dir / "result.json";
    std::error_code ec;
    fs::create_directories(env.scratch_dir, ec);
    MVBRDF_RETURN_IF_ERROR(WriteJsonFile(file, report));
    if (env.report_html) {
      // A light table has nothing to render; the context is the GL thread's.
      MVBRDF_RETURN_IF_ERROR(WriteReportHtml(env, sequence, nullptr));
      out.artifacts.emplace_back("report.html", env.scratch_dir / "report.html");
    }
    out.artifacts.emplace_back("result.json", file);
  }
  report.SerializeToString(&out.result);
  return out;
}

absl::StatusOr<TaskOutput> Reflectance(const v1::Task& task, const scene::Sequence& sequence, TaskEnvironment& env) {
  MVBRDF_ASSIGN_OR_RETURN(pipeline::ReconstructOptions o, OptionsOf(task, env));
  if (task.inputs_size() == 1 && task.inputs(0).kind() == "choose") {
    v1::RunReport table;
    if (!table.ParseFromString(task.inputs(0).result())) {
      return absl::InvalidArgumentError("inputs[0].result: not the choose task's RunReport");
    }
    // The gather's camera refinement, passed on by choose (issue #14).
    if (table.has_calibration()) o.calibration = table.calibration();
    o.light_table = std::move(table);
  } else {
    // No sweep: the key is the known configuration (empty: every light on),
    // the one the request's plan fixes (a given configuration or the only
    // candidate), so that the plan reads as a one-process run's.
    MVBRDF_ASSIGN_OR_RETURN(const pipeline::Plan plan, pipeline::MakePlan(sequence, o.request));
    if (plan.Has(pipeline::Stage::kLightSweep) || plan.fixed_configuration != task.key()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "key: \"", task.key(), "\" is not the configuration the request fixes (\"", plan.fixed_configuration, "\")"));
    }
    // The gather's camera refinement (issue #14); without a gather input
    // (a task made by hand) RunReconstruction refines itself.
    if (task.inputs_size() == 1 && task.inputs(0).kind() == "gather") {
      v1::GatherResult gathered;
      if (!gathered.ParseFromString(task.inputs(0).result())) {
        return absl::InvalidArgumentError("inputs[0].result: not a GatherResult");
      }
      if (gathered.has_calibration()) o.calibration = gathered.calibration();
    }
  }
  o.out_dir = env.scratch_dir;
  o.texel_statistics = std::move(env.texel_statistics);  // consumed: freed as soon as the fits are done
  MVBRDF_ASSIGN_OR_RETURN(const v1::RunReport report, pipeline::RunReconstruction(sequence, *env.gl, o));
  if (env.report_html) MVBRDF_RETURN_IF_ERROR(WriteReportHtml(env, sequence, env.gl));
  TaskOutput out;
  report.SerializeToString(&out.result);
  out.artifacts = FilesUnder(env.scratch_dir);
  for (const v1::CameraErrorRow& c : report.cameras()) {
    if (c.has_mse_brdf()) out.metrics[absl::StrCat("mse_brdf/", c.name())] = c.mse_brdf();
    if (c.has_mse_correction()) out.metrics[absl::StrCat("mse_correction/", c.name())] = c.mse_correction();
  }
  // Flagged cluster fits reach `watch` as metrics "flag/CLUSTER/FLAG" = 1 (it
  // prints them as warnings; result.json's clusters[].flags holds the same).
  for (const v1::ClusterRow& c : report.clusters()) {
    for (const std::string& f : c.flags()) out.metrics[absl::StrCat("flag/", c.name(), "/", f)] = 1.0;
  }
  return out;
}

}  // namespace

absl::StatusOr<TaskOutput> RunTask(const v1::Task& task, const scene::Sequence& sequence,
                                   TaskEnvironment environment) {
  const bool gl = task.kind() == "gather" || task.kind() == "reflectance";
  const int atlas_size = task.request().options().atlas_size() != 0
                             ? static_cast<int>(task.request().options().atlas_size())
                             : atlas::AtlasOptions().size;
  // This worker's memory, not the job's input: another worker may have more
  // (worker_fault.h). Checked up front where it is cheap, caught otherwise.
  if (gl) {
    // The texel pass's reservoir at the default slots (the gather task keeps
    // it when it gathers the texel statistics, else the reflectance task).
    const pipeline::ReconstructOptions defaults;
    const bool texel_pass = task.kind() == "reflectance" || environment.gather_texel_statistics;
    const pipeline::LightLoad lights =
        pipeline::LightLoadOf(sequence, texel_pass ? defaults.reservoir_uniform + defaults.reservoir_highlight : 0,
                              static_cast<int>(std::max<uint32_t>(task.request().options().pixel_footprint(), 1)));
    if (absl::Status fits = pipeline::CheckAtlasFitsInMemory(atlas_size, lights); !fits.ok()) {
      return WorkerFault(absl::ResourceExhaustedError(absl::StrCat("task ", task.kind(), ": ", fits.message())));
    }
  }
  absl::StatusOr<TaskOutput> out = pipeline::CatchOutOfMemory(
      absl::StrCat("task ", task.kind()), gl ? atlas_size : 0, [&]() -> absl::StatusOr<TaskOutput> {
        if (task.kind() == "gather") return Gather(task, sequence, environment);
        if (task.kind() == "sweep") return Sweep(task, sequence, environment);
        if (task.kind() == "choose") return Choose(task, sequence, environment);
        if (task.kind() == "reflectance") return Reflectance(task, sequence, environment);
        return absl::InvalidArgumentError(absl::StrCat("kind: unknown task kind \"", task.kind(), "\""));
      });
  if (!out.ok() && absl::IsResourceExhausted(out.status()) &&
      absl::StrContains(out.status().message(), ": out of memory")) {
    return WorkerFault(out.status());
  }
  return out;
}

}  // namespace mvbrdf::worker
