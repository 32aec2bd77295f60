// The worker-facing gRPC service (issue #5): workers register, lease tasks
// with a long poll, renew their leases and stream progress, artifacts and the
// result (or a failure) of each task back. Jobs, tasks and leases live in
// store::JobStore; artifacts in store::ArtifactStore; triangle Samples in
// store::SampleCache (under TriangleSampleKey, sample_key.h).
//
// The task protocol (docs/service.md): a leased v1::Task carries the results
// of its dependencies (Task.inputs). A `gather` task whose triangle Samples
// are already cached is completed here, on the worker's behalf, with a
// GatherResult{from_cache = true} (the task is marked samples_from_cache, a
// stage started and a stage finished event say so) and the worker gets the
// next task instead. Otherwise the worker resamples and streams the encoded
// Samples (TaskUpdate.samples) before its GatherResult; the server puts them
// in the cache. Workers download bundles with FetchBundle and the cached
// Samples with FetchSamples.
//
// A gather result is refused (INVALID_ARGUMENT, the lease kept) unless the
// complete Samples came first on the same stream and GatherResult.
// samples_sha256 is their digest. Samples larger than the whole Sample cache
// (Put's RESOURCE_EXHAUSTED) fail the attempt at once (FailTask with a reason
// naming sample_cache_max_bytes) and the report answers RESOURCE_EXHAUSTED:
// completing the gather would only let every sweep fail on FetchSamples.
//
// Long polls: a LeaseTask call that finds nothing to do is parked (its
// ServerUnaryReactor kept in a queue) instead of blocking a gRPC thread. One
// background "poller" thread owned by the service serves every parked call in
// arrival order: it tries JobStore::LeaseTask when woken by NotifyWork() (the
// clients API calls it after SubmitJob; completions and failures here call it
// too), by a new or cancelled call, and every `poll_interval_ms` (to pick up
// expired leases, whose expiry is only noticed by asking the store); it
// finishes a call with a task, with an empty response once its wait is over,
// or with CANCELLED when the client went away. So the cost of a waiting
// worker is one queue entry, not a thread, and all lease attempts are
// serialised on one thread (SQLite serialises writers anyway).
//
// Threading: every public method may be called from any thread. The RPC
// handlers run on gRPC's callback threads; they do short SQLite operations
// and, for the final chunk of an artifact, one file write (bounded by
// max_artifact_bytes), for a gather result one Sample cache Put (bounded by
// max_samples_bytes). A cache hit in a lease decodes the cached Samples on
// the poller thread (once per gather task).
//
// Lifetime: the service must outlive the grpc::Server it is registered with.
// grpc::Server::Shutdown() without a deadline waits for in-flight calls, so
// call Stop() first (it answers parked long polls at once), or shut down with
// a deadline (the calls are cancelled and the poller finishes them).
#ifndef MVBRDF_SERVER_WORKERS_API_WORKERS_SERVICE_H_
#define MVBRDF_SERVER_WORKERS_API_WORKERS_SERVICE_H_

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "mvbrdf/v1/service.grpc.pb.h"
#include "server/auth/token_table.h"
#include "server/store/artifact_store.h"
#include "server/store/job_store.h"
#include "server/store/sample_cache.h"

namespace mvbrdf::server {

struct WorkersServiceOptions {
  // How long a lease lasts (s); workers renew at least this often.
  int lease_seconds = 30;
  // Upper bound on LeaseTaskRequest.wait_seconds (s).
  int max_wait_seconds = 20;
  // Largest artifact a worker may send (bytes). Chunks are assembled in
  // memory, so this also bounds the memory of one ReportTask stream per
  // artifact in flight.
  int64_t max_artifact_bytes = int64_t{256} << 20;
  // Largest encoded triangle SampleSet a worker may send with a gather task
  // (bytes); held in memory like an artifact until it is complete.
  int64_t max_samples_bytes = int64_t{1} << 30;
  // How often parked long polls ask the store again without being woken (ms):
  // the latency of picking up an expired lease.
  int poll_interval_ms = 250;
  // The server's tokens (server/auth/authorize.h): every method needs a
  // worker or admin token. Null: authentication off.
  std::shared_ptr<const auth::TokenTable> tokens;

  absl::Status Check() const;
};

// What a worker said about itself when it registered.
struct RegisteredWorker {
  std::string id;  // 32 hex digits
  std::string name;
  std::string gl_renderer;
  uint32_t threads = 0;
  int64_t registered_ms = 0;  // unix ms
  std::string principal;      // the name of the token that registered it; empty with tokens off
};

class WorkersService final : public v1::Workers::CallbackService {
 public:
  // Now as unix ms; tests inject a fake clock. Lease times come from it; the
  // long-poll wait is measured in real (steady) time.
  using Clock = std::function<int64_t()>;
  // Receives every job event this service produces (stage started when a
  // task is leased, progress, stage finished, artifact ready, the job's final
  // state when a completion or failure ended it). Called from gRPC and poller
  // threads, possibly at once, without the service's locks held; may be empty.
  using JobEventSink = std::function<void(const v1::JobEvent&)>;

  // The path of the complete (hash-verified) bundle `sha256` (a validated
  // digest); the file need not exist. Called from gRPC threads.
  using BundlePath = std::function<std::filesystem::path(absl::string_view sha256)>;

  // `jobs`, `artifacts` and `samples` must outlive the service. Aborts on
  // invalid options or a missing clock or bundle_path (programmer errors).
  WorkersService(store::JobStore& jobs, store::ArtifactStore& artifacts, store::SampleCache& samples,
                 BundlePath bundle_path, Clock clock, WorkersServiceOptions options = {},
                 JobEventSink on_event = {});
  // Stops the poller (see Stop()).
  ~WorkersService() override;
  WorkersService(const WorkersService&) = delete;
  WorkersService& operator=(const WorkersService&) = delete;

  // New work may be leasable (a job was submitted, a task finished or was
  // requeued): parked long polls try again now.
  void NotifyWork();
  // Answers every parked long poll with an empty response and stops the
  // poller; later LeaseTask calls answer at once. Idempotent.
  void Stop();

  // The registered worker `worker_id`, if any (workers are kept in memory: a
  // restarted server forgets them and they register again).
  std::optional<RegisteredWorker> FindWorker(absl::string_view worker_id) const;
  std::vector<RegisteredWorker> ListWorkers() const;
  // Its --name (RegisterWorkerRequest.name); empty for an unknown id.
  std::string WorkerName(absl::string_view worker_id) const;

  // The job's events recorded so far, in order, for watchers that join late:
  // stage starts, stage finishes and artifacts all kept; progress only the
  // latest per stage (replaced in place). ForgetJob drops a job's record.
  std::vector<v1::JobEvent> RecordedEvents(absl::string_view job_id) const;
  void ForgetJob(absl::string_view job_id);

  // v1::Workers.
  grpc::ServerUnaryReactor* RegisterWorker(grpc::CallbackServerContext* context,
                                           const v1::RegisterWorkerRequest* request,
                                           v1::RegisterWorkerResponse* response) override;
  grpc::ServerUnaryReactor* LeaseTask(grpc::CallbackServerContext* context, const v1::LeaseTaskRequest* request,
                                      v1::LeaseTaskResponse* response) override;
  grpc::ServerUnaryReactor* RenewLease(grpc::CallbackServerContext* context, const v1::RenewLeaseRequest* request,
                                       v1::RenewLeaseResponse* response) override;
  grpc::ServerReadReactor<v1::TaskUpdate>* ReportTask(grpc::CallbackServerContext* context,
                                                      v1::TaskUpdateAck* ack) override;
  // The complete bundle in 1 MiB chunks. FAILED_PRECONDITION for an
  // unregistered worker, INVALID_ARGUMENT for a malformed digest, NOT_FOUND
  // when the server has no complete bundle of that digest.
  grpc::ServerWriteReactor<v1::ArtifactChunk>* FetchBundle(grpc::CallbackServerContext* context,
                                                           const v1::FetchBundleRequest* request) override;
  // The cached triangle Samples of the task's job in 1 MiB chunks. NOT_FOUND
  // for an unknown task or when the cache has no entry ("no cached Samples
  // for <key>"); FAILED_PRECONDITION when the job is final; DATA_LOSS when
  // the entry was corrupt (it is dropped). Either way the sweep cannot go on:
  // the gather is not re-run yet, so the job fails once the sweep's attempts
  // are used up (an entry evicted mid-job by other jobs' Samples too).
  grpc::ServerWriteReactor<v1::ArtifactChunk>* FetchSamples(grpc::CallbackServerContext* context,
                                                            const v1::FetchSamplesRequest* request) override;

 private:
  class LeasePoll;
  class ReportReactor;

  struct ParkedPoll {
    LeasePoll* reactor;  // owned by gRPC; alive until we Finish() it
    std::string worker_id;
    std::chrono::steady_clock::time_point deadline;
  };

  // Authorize with a worker token (server/auth/authorize.h).
  // The caller's principal when its token may call the Workers service.
  absl::StatusOr<auth::Principal> CheckCaller(const grpc::CallbackServerContext& context) const;
  // `worker_id` is registered, by `caller`'s token (when tokens are on).
  absl::Status CheckWorker(absl::string_view worker_id, const auth::Principal& caller) const;
  int64_t lease_ms() const { return int64_t{options_.lease_seconds} * 1000; }
  // Leases the oldest leasable task for `worker_id` as a v1::Task with its
  // inputs. A task whose job's request cannot be parsed is failed with the
  // reason and the next one tried; a gather task answered from the Sample
  // cache is completed (AnswerGatherFromCache) and the next one tried.
  absl::StatusOr<std::optional<v1::Task>> TryLease(const std::string& worker_id);
  // The results of `task`'s dependencies, in its depends_on order.
  absl::Status FillInputs(const store::Task& task, v1::Task& out);
  // The Samples `task` (leased by `worker_id`) needs are gone from the
  // cache (`why`): its gather dependency runs again and the task waits
  // behind it (JobStore::RedoDependency). Returns the ABORTED status to
  // answer the worker with (NOT_FOUND when the task has no gather).
  absl::Status RegatherFor(const store::Task& task, const std::string& worker_id, const store::SampleKey& key,
                           const std::string& why);
  // Completes a leased gather task from the Sample cache when its Samples
  // are there: true when it did. A corrupt entry (dropped) or a cache error
  // is a miss: the worker resamples.
  absl::StatusOr<bool> AnswerGatherFromCache(const store::Task& task, const std::string& worker_id,
                                             const store::Job& job, const v1::SubmitJobRequest& request);
  // The stored request of `job`; INTERNAL naming the job when it does not parse.
  static absl::StatusOr<v1::SubmitJobRequest> RequestOf(const store::Job& job);
  // The poller thread's loop.
  void ServeParkedPolls();
  // Records `event` (see RecordedEvents) and passes it to the sink.
  void Emit(v1::JobEvent event);
  // After a completion or failure: the job's final state, when it has one.
  void EmitFinalState(const std::string& job_id);

  store::JobStore& jobs_;
  store::ArtifactStore& artifacts_;
  store::SampleCache& samples_;
  const BundlePath bundle_path_;
  const Clock clock_;
  const WorkersServiceOptions options_;
  const JobEventSink on_event_;

  mutable std::mutex workers_mu_;
  std::map<std::string, RegisteredWorker, std::less<>> workers_;  // guarded by workers_mu_

  mutable std::mutex events_mu_;
  std::map<std::string, std::vector<v1::JobEvent>, std::less<>> events_;  // guarded by events_mu_

  std::mutex poll_mu_;
  std::condition_variable poll_cv_;
  std::deque<ParkedPoll> parked_;  // guarded by poll_mu_, arrival order
  bool wake_ = false;              // guarded by poll_mu_
  bool stopping_ = false;          // guarded by poll_mu_
  std::thread poller_;             // started last in the constructor
};

}  // namespace mvbrdf::server

#endif  // MVBRDF_SERVER_WORKERS_API_WORKERS_SERVICE_H_
