// Runs one leased task (docs/service.md, "A job is a task graph") on a
// worker's EGL context and returns what goes back to the server:
//
//   gather       the triangle Samples (pipeline::GatherTriangleSamples),
//                encoded exactly (32-bit floats), and a v1::GatherResult
//   sweep        one row of Table 6.1 (fit::SweepConfigurations on the
//                cached triangle Samples for the task's configuration)
//   choose       a v1::RunReport with the table and the chosen
//                configuration (pipeline::ChooseConfiguration); for a job
//                without reflectance also its result.json artifact
//   reflectance  pipeline::RunReconstruction with the chosen configuration
//                (or the fixed one), every output file as an artifact
//
// The outputs equal those of a one-process RunReconstruction with the same
// options: the sweep rows are computed per configuration exactly as there,
// and the rule that chooses is the same function.
#ifndef MVBRDF_WORKER_TASK_RUNNER_H_
#define MVBRDF_WORKER_TASK_RUNNER_H_

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "core/gl/egl_context.h"
#include "core/pipeline/texel_statistics.h"
#include "core/samples/sample_set.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/service.pb.h"

namespace mvbrdf::worker {

struct TaskEnvironment {
  gl::EglContext* gl = nullptr;
  int threads = 2;
  // The task may write here (the reflectance outputs); the caller removes it.
  std::filesystem::path scratch_dir;
  // Stage progress (frames of a pass; 1 of 1 when a stage ends). May be empty.
  std::function<void(const std::string& stage, int done, int total)> progress;
  // True stops the task with CANCELLED. May be empty.
  std::function<bool()> cancelled;
  // gather: also gather the texel statistics of the job's reflectance task
  // in the same pass (returned in TaskOutput::texel_statistics), for a worker
  // that will run that task itself.
  bool gather_texel_statistics = false;
  // reflectance: pass 1's texel statistics from this worker's gather of the
  // same job, or null (then the task gathers them).
  std::shared_ptr<pipeline::TexelStatistics> texel_statistics;
  // The task that writes the job's result.json (choose for a light table,
  // else reflectance) also writes report.html beside it: the page `mvbrdf
  // report` makes of those outputs (renderings only with `gl`).
  bool report_html = false;
  // The job's triangle Samples (sweep tasks), given its gather's result.
  std::function<absl::StatusOr<std::shared_ptr<const samples::SampleSet>>(const v1::GatherResult&)> samples;
};

struct TaskOutput {
  std::string result;   // TaskUpdate.result
  std::string samples;  // gather: the encoded triangle Samples
  // gather: the same Samples decoded, so the worker's own sweeps need not
  // download them again.
  std::shared_ptr<const samples::SampleSet> sample_set;
  // gather with gather_texel_statistics: for the job's reflectance task.
  std::shared_ptr<pipeline::TexelStatistics> texel_statistics;
  // (artifact name, file) in the order written; names are relative paths
  // such as "atlases/kd.exr".
  std::vector<std::pair<std::string, std::filesystem::path>> artifacts;
  std::map<std::string, double> metrics;  // StageFinished.metrics
  bool samples_from_cache = false;
};

// INVALID_ARGUMENT for an unknown kind or malformed inputs; the pipeline's
// errors otherwise.
absl::StatusOr<TaskOutput> RunTask(const v1::Task& task, const scene::Sequence& sequence,
                                   TaskEnvironment environment);

}  // namespace mvbrdf::worker

#endif  // MVBRDF_WORKER_TASK_RUNNER_H_
