// A worker's own failures (issue #19): its cache disk full or read-only, out
// of memory, no EGL — not the job's input. A task that fails so goes back to
// the queue for another worker (TaskUpdate.worker_fault) instead of using up
// the job's attempts, and the worker stops leasing until it is healthy again.
//
// Where the worker knows the cause (its bundle cache, an allocation that
// failed) it marks the Status with a payload; other failures are judged by a
// probe write into the worker's cache directory (Worker::RunLeased).
#ifndef MVBRDF_WORKER_WORKER_FAULT_H_
#define MVBRDF_WORKER_WORKER_FAULT_H_

#include "absl/status/status.h"
#include "absl/strings/cord.h"

namespace mvbrdf::worker {

inline constexpr char kWorkerFaultPayload[] = "type.mvbrdf/mvbrdf.worker.WorkerFault";

// `status` marked as a failure of the worker's own environment.
inline absl::Status WorkerFault(absl::Status status) {
  status.SetPayload(kWorkerFaultPayload, absl::Cord("1"));
  return status;
}

inline bool IsMarkedWorkerFault(const absl::Status& status) {
  return status.GetPayload(kWorkerFaultPayload).has_value();
}

}  // namespace mvbrdf::worker

#endif  // MVBRDF_WORKER_WORKER_FAULT_H_
