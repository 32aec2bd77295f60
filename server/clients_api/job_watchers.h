// WatchJob's server side: the streams of job events to clients.
//
// Each watch is a ServerWriteReactor (one per RPC, owned by gRPC until
// OnDone). It first replays the job's current state (its state, a
// StageStarted naming the worker for every task leased so far, a
// StageFinished for every task done so far, the reason when failed), then
// follows the job: one poller thread (owned here) reads the store every
// `poll_interval` for every watched job and sends a JobState event when the
// state changed and a StageFinished per newly done task (the worker's report
// kept with the task: its seconds and metrics, key and worker name); other
// parts of the server forward stage starts, progress and artifacts with Push
// (Push drops finished stages and states: those come from the store, once). A stream ends after a final state
// (succeeded, failed, cancelled). A client cancelling its watch only ends the
// stream, never the job.
//
// Threading: Watch and Push may be called from any thread. The reactors'
// callbacks run on gRPC's threads. The poller never holds a lock while it
// reads the store.
#ifndef MVBRDF_SERVER_CLIENTS_API_JOB_WATCHERS_H_
#define MVBRDF_SERVER_CLIENTS_API_JOB_WATCHERS_H_

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>

#include <grpcpp/support/server_callback.h>

#include "mvbrdf/v1/service.pb.h"
#include "server/store/job_store.h"

namespace mvbrdf::clients_api {

class JobWatch;

class JobWatchers {
 public:
  // `jobs` and `clock` (unix ms, for event times) must outlive this object.
  JobWatchers(store::JobStore& jobs, std::function<int64_t()> clock, std::chrono::milliseconds poll_interval);
  // Stops the poller. The gRPC server must be shut down first (its watches
  // are then finished).
  ~JobWatchers();
  JobWatchers(const JobWatchers&) = delete;
  JobWatchers& operator=(const JobWatchers&) = delete;

  // The reactor of one WatchJob call (NOT_FOUND for an unknown job).
  grpc::ServerWriteReactor<v1::JobEvent>* Watch(const std::string& job_id);
  // Sends `event` to the current watchers of event.job_id.
  void Push(const v1::JobEvent& event);
  // Watch streams gRPC has not yet released (OnDone not yet run): every one
  // ends once its client cancels or its job reaches a final state.
  size_t ActiveWatches() const;

 private:
  friend class JobWatch;
  void Remove(JobWatch* watch);
  void PollLoop();
  void PollOnce();

  store::JobStore& jobs_;
  const std::function<int64_t()> clock_;
  const std::chrono::milliseconds poll_interval_;

  mutable std::mutex mu_;
  std::condition_variable wake_;
  bool stop_ = false;                                  // guarded by mu_
  size_t active_ = 0;                                  // guarded by mu_
  std::map<std::string, std::set<JobWatch*>> watches_;  // by job id; guarded by mu_
  std::thread poller_;
};

}  // namespace mvbrdf::clients_api

#endif  // MVBRDF_SERVER_CLIENTS_API_JOB_WATCHERS_H_
