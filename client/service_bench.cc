// Benchmark of the service's light sweep (issue #5): wall time of a
// light-table job (gather, one sweep task per configuration, choose) on an
// in-process server with 1 and 2 single-threaded workers and with 1 worker
// running 2 sweeps at once, cold (the triangle Samples are computed) and warm
// (the same job again: gather is answered from the Sample cache; the warm
// gather task's own time is reported beside the cold one, the part of the job
// the cache serves). The sweep is the report's light_sweep stage: from the
// first sweep task's start to the last one's end (a second worker's download
// of the Samples included); after_gather_seconds is the job's wall time less
// the gather's (submission, hand-overs and choose too). Prints one JSON
// object; scripts/bench-service writes it to out/bench/service.json.
// Usage: service_bench SCENE [REPETITIONS]
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/bundle_upload.h"
#include "client/embedded_service.h"
#include "core/base/files.h"
#include "core/bundle/bundle.h"

namespace mvbrdf::client {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : (v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]));
}

struct JobTimes {
  double wall = 0.0;       // submit to succeeded
  double gather = 0.0;     // the gather task's run time
  double after_gather = 0.0;  // wall minus gather: the sweep tasks, choose and the service's hand-overs
  // The report's light_sweep stage: from the first sweep task's start to the
  // last one's end, on the server's clock (a worker's first Sample download
  // included; the job's submission, the gather's upload and choose not).
  double sweep = 0.0;
  int workers_used = 0;
  bool cache_hit = false;
};

absl::StatusOr<JobTimes> RunJob(v1::Mvbrdf::Stub& stub, const v1::SubmitJobRequest& request) {
  JobTimes times;
  const auto start = Clock::now();
  v1::SubmitJobResponse submitted;
  {
    grpc::ClientContext context;
    const grpc::Status status = stub.SubmitJob(&context, request, &submitted);
    if (!status.ok()) return absl::InternalError(status.error_message());
  }
  v1::Job job;
  for (;;) {
    grpc::ClientContext context;
    v1::ListJobsRequest list;
    v1::ListJobsResponse response;
    const grpc::Status status = stub.ListJobs(&context, list, &response);
    if (!status.ok()) return absl::InternalError(status.error_message());
    for (const v1::Job& j : response.jobs()) {
      if (j.id() == submitted.job().id()) job = j;
    }
    if (job.state() == v1::SUCCEEDED) break;
    if (job.state() == v1::FAILED || job.state() == v1::CANCELLED) {
      return absl::InternalError(absl::StrCat("job ended: ", job.error()));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  times.wall = std::chrono::duration<double>(Clock::now() - start).count();
  std::vector<std::string> workers;
  for (const v1::TaskInfo& t : job.tasks()) {
    if (t.kind() == "gather") {
      times.gather = t.seconds();
      times.cache_hit = t.samples_from_cache();
    }
    if (t.kind() == "sweep" && std::find(workers.begin(), workers.end(), t.worker()) == workers.end()) {
      workers.push_back(t.worker());
    }
  }
  times.workers_used = static_cast<int>(workers.size());
  times.after_gather = times.wall - times.gather;
  for (const v1::StageRow& stage : job.report().stages()) {
    if (stage.name() == "light_sweep") times.sweep = stage.seconds();
  }
  if (!(times.sweep > 0.0)) return absl::InternalError("the job's report has no light_sweep stage");
  return times;
}

int Main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: service_bench SCENE [REPETITIONS]\n");
    return 2;
  }
  const fs::path scene = argv[1];
  const int repetitions = argc > 2 ? std::atoi(argv[2]) : 3;
  const absl::StatusOr<fs::path> tmp = TemporaryDirectory();
  if (!tmp.ok()) {
    std::fprintf(stderr, "service_bench: %s\n", std::string(tmp.status().message()).c_str());
    return 4;
  }
  const fs::path base = *tmp / ("mvbrdf-service-bench-" + std::to_string(getpid()));
  fs::remove_all(base);
  auto info = bundle::PackBundle(scene, base / "bundle.tar");
  if (!info.ok()) {
    std::fprintf(stderr, "%s\n", std::string(info.status().message()).c_str());
    return 1;
  }
  std::string rows;
  // (workers, threads per worker): one or two single-threaded workers, and
  // one worker running two CPU-only tasks (sweeps) at once.
  const std::vector<std::pair<int, int>> setups = {{1, 1}, {2, 1}, {1, 2}};
  std::vector<double> cold_median(setups.size()), sweep_median(setups.size()), warm_median(setups.size());
  std::vector<double> warm_sweep_median(setups.size());
  // The part of the job the cache serves: the gather task, cold and warm.
  std::vector<double> gather_median(setups.size()), warm_gather_median(setups.size());
  for (size_t setup = 0; setup < setups.size(); ++setup) {
    const int workers = setups[setup].first, threads = setups[setup].second;
    std::vector<double> cold, sweep, after_gather, warm, warm_sweep, gather, warm_gather;
    int used = 0;
    for (int r = 0; r < repetitions; ++r) {
      EmbeddedOptions eo;
      eo.data_dir = base / absl::StrCat("data-", setup, "-", r);
      eo.workers = workers;
      eo.egl = gl::EglPlatform::kSurfaceless;
      eo.threads_per_worker = threads;
      auto service = EmbeddedService::Start(eo);
      if (!service.ok()) return 1;
      auto stub = v1::Mvbrdf::NewStub((*service)->channel());
      UploadOutcome outcome;
      if (!UploadBundleFile(*stub, "bench", base / "bundle.tar", info->sha256, static_cast<uint64_t>(info->size),
                            nullptr, &outcome).ok()) {
        return 1;
      }
      v1::SubmitJobRequest request;
      request.set_bundle_sha256(info->sha256);
      request.set_scene_path(scene.filename().string());
      request.add_outputs(v1::OUTPUT_LIGHT_TABLE);
      auto first = RunJob(*stub, request);
      auto second = first.ok() ? RunJob(*stub, request) : first;
      if (!first.ok() || !second.ok()) {
        std::fprintf(stderr, "%s\n", std::string((first.ok() ? second : first).status().message()).c_str());
        return 1;
      }
      if (first->cache_hit || !second->cache_hit) {
        std::fprintf(stderr, "unexpected cache behaviour (cold hit %d, warm hit %d)\n", first->cache_hit,
                     second->cache_hit);
        return 1;
      }
      cold.push_back(first->wall);
      gather.push_back(first->gather);
      sweep.push_back(first->sweep);
      after_gather.push_back(first->after_gather);
      warm.push_back(second->wall);
      warm_sweep.push_back(second->sweep);
      warm_gather.push_back(second->gather);
      used = std::max(used, first->workers_used);
      std::fprintf(stderr,
                   "workers %d x %d threads, rep %d: cold %.2f s (gather %.2f, sweep %.2f, after the gather %.2f), "
                   "warm %.2f s (sweep %.2f)\n",
                   workers, threads, r, first->wall, first->gather, first->sweep, first->after_gather, second->wall,
                   second->sweep);
    }
    cold_median[setup] = Median(cold);
    sweep_median[setup] = Median(sweep);
    warm_sweep_median[setup] = Median(warm_sweep);
    warm_median[setup] = Median(warm);
    gather_median[setup] = Median(gather);
    warm_gather_median[setup] = Median(warm_gather);
    absl::StrAppend(&rows, rows.empty() ? "" : ",\n", "    {\"workers\": ", workers, ", \"threads_per_worker\": ", threads,
                    ", \"repetitions\": ", repetitions,
                    ", \"workers_that_swept\": ", used, ", \"cold_job_seconds\": ", cold_median[setup],
                    ", \"gather_seconds\": ", Median(gather), ", \"sweep_seconds\": ", sweep_median[setup],
                    ", \"after_gather_seconds\": ", Median(after_gather), ", \"warm_job_seconds\": ",
                    warm_median[setup], ", \"warm_sweep_seconds\": ", warm_sweep_median[setup],
                    ", \"warm_gather_seconds\": ", warm_gather_median[setup], "}");
  }
  std::printf("{\n  \"scene\": \"%s\",\n  \"job\": \"light table (gather, 1 sweep task per configuration, choose)\",\n"
              "  \"medians\": [\n%s\n  ],\n  \"sweep_speedup_2_workers\": %.3f,\n  \"job_speedup_2_workers\": %.3f,\n"
              "  \"warm_sweep_speedup_2_workers\": %.3f,\n"
              "  \"sweep_speedup_1_worker_2_threads\": %.3f,\n"
              "  \"warm_cache_speedup_1_worker\": %.3f,\n  \"warm_cache_speedup_2_workers\": %.3f,\n"
              "  \"warm_cache_speedup_gather_1_worker\": %.3f\n}\n",
              scene.string().c_str(), rows.c_str(), sweep_median[0] / sweep_median[1], cold_median[0] / cold_median[1],
              warm_sweep_median[0] / warm_sweep_median[1], sweep_median[0] / sweep_median[2], cold_median[0] / warm_median[0], cold_median[1] / warm_median[1],
              gather_median[0] / std::max(warm_gather_median[0], 1e-3));
  fs::remove_all(base);
  return 0;
}

}  // namespace
}  // namespace mvbrdf::client

int main(int argc, char** argv) { return mvbrdf::client::Main(argc, argv); }
