// The worker-facing gRPC service (issue #5): workers register, lease tasks
// with a long poll, renew their leases and stream progress, artifacts and the
// result (or a failure) of each task back. Jobs, tasks and leases live in
// store::JobStore; artifacts in store::ArtifactStore.
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
// max_artifact_bytes).
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
#include <functional>
#include <map>
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
#include "server/store/artifact_store.h"
#include "server/store/job_store.h"

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
  // How often parked long polls ask the store again without being woken (ms):
  // the latency of picking up an expired lease.
  int poll_interval_ms = 250;

  absl::Status Check() const;
};

// What a worker said about itself when it registered.
struct RegisteredWorker {
  std::string id;  // 32 hex digits
  std::string name;
  std::string gl_renderer;
  uint32_t threads = 0;
  int64_t registered_ms = 0;  // unix ms
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

  // `jobs` and `artifacts` must outlive the service. CHECKs options.Check().
  WorkersService(store::JobStore& jobs, store::ArtifactStore& artifacts, Clock clock,
                 WorkersServiceOptions options = {}, JobEventSink on_event = {});
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

 private:
  class LeasePoll;
  class ReportReactor;

  struct ParkedPoll {
    LeasePoll* reactor;  // owned by gRPC; alive until we Finish() it
    std::string worker_id;
    std::chrono::steady_clock::time_point deadline;
  };

  absl::Status CheckWorker(absl::string_view worker_id) const;
  int64_t lease_ms() const { return int64_t{options_.lease_seconds} * 1000; }
  // Leases the oldest leasable task for `worker_id` as a v1::Task. A task
  // whose job's request cannot be parsed is failed with the reason and the
  // next one tried.
  absl::StatusOr<std::optional<v1::Task>> TryLease(const std::string& worker_id);
  // The poller thread's loop.
  void ServeParkedPolls();
  // Records `event` (see RecordedEvents) and passes it to the sink.
  void Emit(v1::JobEvent event);
  // After a completion or failure: the job's final state, when it has one.
  void EmitFinalState(const std::string& job_id);

  store::JobStore& jobs_;
  store::ArtifactStore& artifacts_;
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
