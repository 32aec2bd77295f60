// The worker process's loop (issue #5, docs/service.md "Worker loop"): one
// EGL context, registered with the server; leases a task (long poll), runs it
// (worker/task_runner.h) while a second thread renews the lease, and streams
// progress, the stage's metrics, Samples, artifacts and the result back over
// one ReportTask call; then the next task. Bundles are downloaded once into
// a local cache (worker/bundle_cache.h); the triangle Samples of a sweep are
// downloaded once per job and kept for the next sweep task.
//
// A lost lease (renewal refused: the task was leased again, or its job was
// cancelled or failed) stops the task at its next frame; the server has
// already given it to someone else, so nothing is reported.
//
// GL tasks (gather, reflectance) run one at a time on Run()'s thread, which
// owns the EGL context; CPU-only tasks (sweep, choose) run beside each other
// on their own threads, up to `threads` at once, so a worker sweeps several
// configurations in parallel.
//
// Threading: Run() on one thread (the EGL context is created current on it);
// Stop() from any thread.
#ifndef MVBRDF_WORKER_WORKER_H_
#define MVBRDF_WORKER_WORKER_H_

#include <atomic>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include <grpcpp/grpcpp.h>

#include "absl/status/status.h"
#include "core/gl/egl_context.h"
#include "core/pipeline/texel_statistics.h"
#include "core/samples/sample_set.h"
#include "mvbrdf/v1/service.grpc.pb.h"

namespace mvbrdf::worker {

struct WorkerOptions {
  // The server's Workers service.
  std::shared_ptr<grpc::Channel> channel;
  std::string name;                   // for people: who ran a task
  std::filesystem::path cache_dir;    // bundles and scratch space
  // Bundles already verified and unpacked as <dir>/<sha256>/ by a server on
  // this machine (the embedded service's scenes/ directory, which it fills
  // when it validates a job): used where they are instead of downloading the
  // bundle and unpacking it again (issue #17: for bench-e2e's 518 MB bundle
  // a gRPC copy, a file and a second unpack). Empty: always download.
  std::filesystem::path server_unpacked_bundles;
  gl::EglPlatform egl = gl::EglPlatform::kAuto;
  int threads = 2;                    // CPU-only tasks at once
  int wait_seconds = 5;               // long poll per LeaseTask call
  // One line per event (registered, task leased, done, failed); may be empty.
  std::function<void(const std::string&)> log;
  // Stop after this many tasks (0: never); for tests and one-shot workers.
  int max_tasks = 0;
  // A gather also collects the texel statistics of its job's reflectance
  // task, kept here for when this worker leases that task (one pass over
  // the frames instead of two). Worth it when this worker will likely run
  // the reflectance too: a single worker (mvbrdf run's default).
  bool gather_texel_statistics = false;
  // The job's report.html is one of its artifacts (TaskEnvironment::
  // report_html). Off for `mvbrdf run`'s in-process workers: run writes its
  // own with --report, from the outputs in --out.
  bool report_html = true;
};

class Worker {
 public:
  explicit Worker(WorkerOptions options) : options_(std::move(options)) {}

  // Creates the EGL context, registers, and leases and runs tasks until
  // Stop() (then OK, after the task in hand is finished). UNAVAILABLE while
  // the server is unreachable is retried; other errors of the worker's own
  // (EGL, cache directory) are returned.
  absl::Status Run();
  // Ends Run() after the current task (a waiting long poll is cancelled).
  void Stop();

  std::string id() const;
  int tasks_run() const { return tasks_run_; }
  // Tasks that failed on this worker's own environment (TaskUpdate.worker_fault).
  int own_faults_reported() const { return own_faults_reported_; }
  int bundle_downloads() const { return bundle_downloads_; }
  int samples_downloads() const { return samples_downloads_; }

 private:
  absl::Status Register(v1::Workers::Stub& stub, const gl::EglContext& context);
  absl::Status RunLeased(v1::Workers::Stub& stub, const v1::Task& task, gl::EglContext& context,
                         class BundleCache& cache);
  absl::StatusOr<std::shared_ptr<const samples::SampleSet>> FetchSamples(v1::Workers::Stub& stub,
                                                                         const v1::Task& task,
                                                                         const v1::GatherResult& gathered);
  void Log(const std::string& line) const;

  const WorkerOptions options_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mu_;
  std::string id_;                           // guarded by mu_
  grpc::ClientContext* poll_ = nullptr;      // guarded by mu_: the long poll in flight
  std::atomic<int> lease_seconds_{30};  // set by Register, read by task threads
  std::atomic<int> tasks_run_{0};
  // Tasks in a row that failed on this worker's own environment
  // (worker_fault.h), and until when (steady clock, ms) not to lease after
  // the last; reset by a task that succeeds. Any thread.
  std::atomic<int> own_faults_{0};
  std::atomic<int64_t> backoff_until_ms_{0};
  void NoteTaskOutcome(bool own_fault);
  // Blocks (until Stop()) while this worker should not lease: in the back-off
  // after its own failure, or while its cache directory fails a probe write.
  void WaitUntilHealthy();
  std::atomic<int> bundle_downloads_{0};
  std::atomic<int> own_faults_reported_{0};
  std::atomic<int> samples_downloads_{0};
  // The last job's triangle Samples, by the SHA-256 of their encoding.
  std::mutex samples_mu_;
  std::string samples_sha256_;                         // guarded by samples_mu_
  std::shared_ptr<const samples::SampleSet> samples_;  // guarded by samples_mu_
  std::mutex cache_mu_;  // the bundle cache, shared by concurrent tasks
  std::mutex texels_mu_;
  std::string texels_job_;                             // guarded by texels_mu_
  std::shared_ptr<pipeline::TexelStatistics> texels_;  // guarded by texels_mu_
};

}  // namespace mvbrdf::worker

#endif  // MVBRDF_WORKER_WORKER_H_
