// Jobs and their tasks, with leases, in SQLite (issue #5).
//
// A job is one client request (the serialized request proto is opaque here);
// its stages are tasks in a graph: a task may depend on one other task of the
// same job and is not leased before that task is done. Workers lease tasks for
// a time and renew the lease while they work; a task whose lease expires is
// leased again to any worker (at-least-once: tasks must be idempotent), and
// every lease counts an attempt.
//
// Task states:  queued -> leased -> done
//                  ^        |  \--> failed     (FailTask at max_attempts;
//                  |        |                   lease expired at max_attempts)
//                  +--------+ (FailTask below max_attempts; lease expiry)
//               queued/leased -> cancelled     (CancelJob, or the job failed)
// Job states: queued until a task is leased, then running; succeeded when
// every task is done; failed when a task fails for good; cancelled by
// CancelJob. The last three are final.
//
// Time is always passed in (unix ms): the store has no clock, so tests are
// deterministic and the server decides what "now" is.
//
// Threading: every method may be called from any thread; a mutex serialises
// the operations of one JobStore. Several JobStores (or processes) on the same
// file coordinate through SQLite's write lock (BEGIN IMMEDIATE), so a task is
// never leased to two workers at once.
#ifndef MVBRDF_SERVER_STORE_JOB_STORE_H_
#define MVBRDF_SERVER_STORE_JOB_STORE_H_

#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/store/sqlite_db.h"

namespace mvbrdf::store {

enum class JobState { kQueued, kRunning, kSucceeded, kFailed, kCancelled };
enum class TaskState { kQueued, kLeased, kDone, kFailed, kCancelled };

// The names stored in the database ("queued", "running", ...).
absl::string_view JobStateName(JobState state);
absl::string_view TaskStateName(TaskState state);
absl::StatusOr<JobState> ParseJobState(absl::string_view name);
absl::StatusOr<TaskState> ParseTaskState(absl::string_view name);
bool IsFinal(JobState state);

struct Job {
  std::string id;  // 32 hex digits (128 random bits)
  std::string client;
  JobState state = JobState::kQueued;
  std::string scene_hash;  // SHA-256 hex of the sequence bundle
  std::string request;     // opaque bytes (the serialized request message)
  std::string error;       // why it failed; empty otherwise
  int64_t created_ms = 0;
  int64_t updated_ms = 0;
};

struct Task {
  std::string id;  // 32 hex digits
  std::string job_id;
  std::string kind;  // the stage, e.g. "sweep", "texel"
  std::string key;   // what the stage runs on, e.g. the light configuration
  std::optional<std::string> depends_on;  // a task of the same job
  TaskState state = TaskState::kQueued;
  int attempts = 0;  // leases handed out so far
  int max_attempts = 0;
  // The worker of the current (or last) lease; kept after the task finishes
  // so that reports can say who ran it.
  std::string lease_owner;
  int64_t lease_expires_ms = 0;  // 0 when not leased
  std::optional<std::string> result;  // set when done
  std::string error;                  // the last failure reported
  int64_t created_ms = 0;
  int64_t updated_ms = 0;
};

struct NewJob {
  std::string client;
  std::string scene_hash;
  std::string request;
};

struct NewTask {
  std::string job_id;
  std::string kind;
  std::string key;
  std::optional<std::string> depends_on;
  // 0: JobStoreOptions::default_max_attempts.
  int max_attempts = 0;
};

struct JobStoreOptions {
  // Leases a task gets (failures and expiries included) before it fails for
  // good and takes its job with it.
  int default_max_attempts = 3;

  absl::Status Check() const;
};

class JobStore {
 public:
  // Opens (creating and migrating) the database at `path`.
  static absl::StatusOr<std::unique_ptr<JobStore>> Open(const std::filesystem::path& path,
                                                        JobStoreOptions options = {});

  // A queued job without tasks; returns its id.
  absl::StatusOr<std::string> CreateJob(const NewJob& job, int64_t now_ms);
  // Adds a queued task to a job that is not final; returns its id.
  // INVALID_ARGUMENT when depends_on is not a task of the same job.
  absl::StatusOr<std::string> AddTask(const NewTask& task, int64_t now_ms);

  // Atomically leases the oldest task (by creation) that is either queued
  // with its dependency done, or leased with an expired lease, whose kind is
  // in `kinds` (empty: any kind) and whose job is not final. Bumps attempts.
  // nullopt when there is nothing to do. Tasks whose lease expired at
  // max_attempts fail here (and fail their job).
  absl::StatusOr<std::optional<Task>> LeaseTask(absl::string_view worker, int64_t now_ms, int64_t lease_ms,
                                                const std::vector<std::string>& kinds = {});
  // Extends the lease to now + lease_ms. FAILED_PRECONDITION unless the task
  // is leased by `worker` (another worker may have taken over an expired lease).
  absl::Status RenewLease(absl::string_view task_id, absl::string_view worker, int64_t now_ms, int64_t lease_ms);
  // Marks the task done with its result; the job succeeds when it was the
  // last task. Only the lease owner may complete; completing again with the
  // same result is OK (a retried RPC), with a different result
  // FAILED_PRECONDITION.
  absl::Status CompleteTask(absl::string_view task_id, absl::string_view worker, absl::string_view result,
                            int64_t now_ms);
  // The owner reports a failure: the task is queued again while attempts <
  // max_attempts, else it fails, its job fails with `error`, and the job's
  // other queued/leased tasks are cancelled.
  absl::Status FailTask(absl::string_view task_id, absl::string_view worker, absl::string_view error,
                        int64_t now_ms);
  // Cancels the job and its queued and leased tasks (a worker holding a
  // lease learns it when its next renew/complete fails). Cancelling a
  // cancelled job is OK; a succeeded or failed one is FAILED_PRECONDITION.
  absl::Status CancelJob(absl::string_view job_id, int64_t now_ms);

  absl::StatusOr<Job> GetJob(absl::string_view job_id);
  // The client's jobs, oldest first.
  absl::StatusOr<std::vector<Job>> ListJobs(absl::string_view client);
  // The job's tasks, in creation order.
  absl::StatusOr<std::vector<Task>> TasksOfJob(absl::string_view job_id);
  absl::StatusOr<Task> GetTask(absl::string_view task_id);

 private:
  JobStore(std::unique_ptr<SqliteDb> db, JobStoreOptions options) : db_(std::move(db)), options_(options) {}

  // Helpers run with mu_ held, inside a transaction where they write.
  absl::StatusOr<Job> GetJobLocked(absl::string_view job_id);
  absl::StatusOr<Task> GetTaskLocked(absl::string_view task_id);
  absl::StatusOr<Task> GetLeasedTaskOf(absl::string_view task_id, absl::string_view worker,
                                       absl::string_view operation);
  absl::Status SetJobState(absl::string_view job_id, JobState state, absl::string_view error, int64_t now_ms);
  absl::Status FailJobLocked(absl::string_view job_id, absl::string_view error, int64_t now_ms);
  absl::Status FailExpiredLeases(int64_t now_ms);
  // Recomputes a non-final job's state from its tasks.
  absl::Status RefreshJobState(absl::string_view job_id, int64_t now_ms);

  std::mutex mu_;
  std::unique_ptr<SqliteDb> db_;  // guarded by mu_
  const JobStoreOptions options_;
};

}  // namespace mvbrdf::store

#endif  // MVBRDF_SERVER_STORE_JOB_STORE_H_
