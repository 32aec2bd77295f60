// Jobs and their tasks, with leases, in SQLite (issue #5).
//
// A job is one client request (the serialized request proto is opaque here);
// its stages are tasks in a graph: a task may depend on any number of earlier
// tasks of the same job and is not leased before all of them are done (a
// sweep fans out as one task per configuration; a "choose" task depending on
// all of them fans in). The graph grows in two ways: the server adds tasks
// (AddTask) and then seals the job (SealJob) once it has added all it will;
// and the worker completing a task may add follow-up tasks in the same
// transaction (CompleteTask with follow_ups), also after sealing — e.g. the
// per-texel tasks once "choose" knows the best configuration. Workers lease tasks for
// a time and renew the lease while they work; a task whose lease expires is
// leased again to any worker (at-least-once: tasks must be idempotent), and
// every lease counts an attempt.
//
// Task states:  queued -> leased -> done
//                  ^        |  \--> failed     (FailTask at max_attempts;
//                  |        |                   lease expired at max_attempts)
//                  +--------+ (FailTask below max_attempts; lease expiry)
//               queued/leased -> cancelled     (CancelJob, or the job failed)
// A task failing for good fails the tasks that depend on it, directly or not
// (their error names it), and cancels the job's other queued/leased tasks.
// Job states: queued until a task is leased, then running; succeeded when it
// is sealed and every task is done; failed when a task fails for good;
// cancelled by CancelJob. The last three are final.
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
#include <initializer_list>
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
  bool sealed = false;     // SealJob was called: no more AddTask
  int64_t created_ms = 0;
  int64_t updated_ms = 0;
};

// Task ids a new task depends on: none, one or many. Converts from the forms
// callers have at hand (nullopt, one id, an optional id, a vector, a braced
// list), so that NewTask{job, kind, key, dependency, 0} keeps compiling.
class TaskIds : public std::vector<std::string> {
 public:
  TaskIds() = default;
  TaskIds(std::nullopt_t) {}                                                 // NOLINT: implicit
  TaskIds(std::string id) { push_back(std::move(id)); }                      // NOLINT: implicit
  TaskIds(const char* id) { emplace_back(id); }                              // NOLINT: implicit
  TaskIds(std::optional<std::string> id) {                                   // NOLINT: implicit
    if (id.has_value()) push_back(std::move(*id));
  }
  TaskIds(std::vector<std::string> ids) : std::vector<std::string>(std::move(ids)) {}  // NOLINT: implicit
  TaskIds(std::initializer_list<std::string> ids) : std::vector<std::string>(ids) {}
};

// In CompleteTask's follow_ups, a dependency on the follow-up at `index` of
// the same call (whose id is not known yet); index < the dependent's own.
std::string FollowUpRef(int index);

struct Task {
  std::string id;  // 32 hex digits
  std::string job_id;
  std::string kind;  // the stage, e.g. "sweep", "texel"
  std::string key;   // what the stage runs on, e.g. the light configuration
  std::vector<std::string> depends_on;  // tasks of the same job, in the order given
  std::optional<std::string> added_by;  // the task whose completion added this one
  TaskState state = TaskState::kQueued;
  int attempts = 0;  // leases handed out so far
  int max_attempts = 0;
  // The worker of the current (or last) lease; kept after the task finishes
  // so that reports can say who ran it.
  std::string lease_owner;
  int64_t lease_expires_ms = 0;  // 0 when not leased
  // When the current (or last) lease was handed out (unix ms); 0 before the
  // first lease. With updated_ms of a done or failed task: how long it ran.
  int64_t started_ms = 0;
  // The task ran on Samples the Sample cache already held (SetSamplesFromCache).
  bool samples_from_cache = false;
  // Failures workers reported as their own environment's (FailTask's
  // worker_fault); they did not count as attempts.
  int worker_faults = 0;
  std::optional<std::string> result;  // set when done
  std::string error;                  // the last failure reported
  // The --name lease_owner registered with (RegisterWorker); empty when unknown.
  std::string worker_name;
  // The worker's report of the finished stage (SetStageFinished; opaque).
  std::optional<std::string> stage_finished;
  int64_t created_ms = 0;
  int64_t updated_ms = 0;
};

struct NewJob {
  std::string client;
  std::string scene_hash;
  std::string request;
};

struct NewTask {
  // In CompleteTask's follow_ups, empty means the completed task's job.
  std::string job_id;
  std::string kind;
  std::string key;
  // Tasks of the same job (duplicates are ignored); in follow_ups also
  // FollowUpRef(i) for an earlier follow-up of the same call.
  TaskIds depends_on;
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
  // Adds a queued task to a job that is neither final nor sealed; returns its
  // id. INVALID_ARGUMENT when a dependency is not a task of the same job;
  // FAILED_PRECONDITION when the job is final or sealed.
  absl::StatusOr<std::string> AddTask(const NewTask& task, int64_t now_ms);
  // The server has added every task it will add (completions may still add
  // follow-ups): the job succeeds once all its tasks are done — at once when
  // they already are. Sealing again is OK. FAILED_PRECONDITION when the job
  // has no tasks (it could never finish) or is failed or cancelled.
  absl::Status SealJob(absl::string_view job_id, int64_t now_ms);

  // Atomically leases the oldest task (by creation) that is either queued
  // with all its dependencies done, or leased with an expired lease, whose kind is
  // in `kinds` (empty: any kind) and whose job is not final. Bumps attempts.
  // nullopt when there is nothing to do. Tasks whose lease expired at
  // max_attempts fail here (and fail their job).
  absl::StatusOr<std::optional<Task>> LeaseTask(absl::string_view worker, int64_t now_ms, int64_t lease_ms,
                                                const std::vector<std::string>& kinds = {});
  // Extends the lease to now + lease_ms. FAILED_PRECONDITION unless the task
  // is leased by `worker` (another worker may have taken over an expired lease).
  absl::Status RenewLease(absl::string_view task_id, absl::string_view worker, int64_t now_ms, int64_t lease_ms);
  // Marks the task done with its result; the job succeeds when it is sealed
  // and this was the last task. Only the lease owner may complete; completing
  // again with the same result is OK (a retried RPC), with a different result
  // FAILED_PRECONDITION.
  absl::Status CompleteTask(absl::string_view task_id, absl::string_view worker, absl::string_view result,
                            int64_t now_ms);
  // The same, and adds `follow_ups` to the task's job in the same
  // transaction (allowed on a sealed job: the job cannot have succeeded while
  // this task was leased). Returns the follow-ups' ids in order; a retried
  // completion adds nothing again and returns the ids of the first. A bad
  // follow-up (INVALID_ARGUMENT) leaves the task leased and adds nothing.
  absl::StatusOr<std::vector<std::string>> CompleteTask(absl::string_view task_id, absl::string_view worker,
                                                        absl::string_view result, int64_t now_ms,
                                                        const std::vector<NewTask>& follow_ups);
  // The owner reports a failure: the task is queued again while attempts <
  // max_attempts, else it fails, its job fails with `error`, and the job's
  // other queued/leased tasks are cancelled. `permanent`: the failure would
  // recur on any worker (bad input, a limit), so the task fails at once.
  // `worker_fault`: the failure is the worker's own environment's (its disk,
  // memory, EGL), not the job's: the task is queued again for another worker
  // and the attempt is given back, up to 2 * max_attempts such failures per
  // task (then it fails like the last attempt, so a job no worker can run
  // still ends).
  absl::Status FailTask(absl::string_view task_id, absl::string_view worker, absl::string_view error, int64_t now_ms,
                        bool permanent = false, bool worker_fault = false);
  // The lease owner of `task_id` cannot run it because the output of its
  // done dependency `dependency_id` is gone (the Samples a gather put in the
  // Sample cache were evicted or found corrupt): the dependency is queued
  // again (its result cleared) unless it already is, and `task_id` goes back
  // to queued behind it without its lease counting as an attempt. When the
  // dependency has used up its attempts, `task_id` fails instead, and its
  // job with `reason` (no endless redo when the cache cannot hold the
  // Samples). FAILED_PRECONDITION unless `task_id` is leased by `worker`;
  // INVALID_ARGUMENT unless `dependency_id` is one of its dependencies.
  absl::Status RedoDependency(absl::string_view task_id, absl::string_view worker, absl::string_view dependency_id,
                              absl::string_view reason, int64_t now_ms);
  // Cancels the job and its queued and leased tasks (a worker holding a
  // lease learns it when its next renew/complete fails). Cancelling a
  // cancelled job is OK; a succeeded or failed one is FAILED_PRECONDITION.
  absl::Status CancelJob(absl::string_view job_id, int64_t now_ms);

  // Records whether the task's Samples came from the Sample cache (shown in
  // job reports). Any state; NOT_FOUND for an unknown task. Does not touch
  // updated_ms (it times the task).
  absl::Status SetSamplesFromCache(absl::string_view task_id, bool from_cache);
  // Records a worker and its name (kept after it goes away, so tasks it ran
  // still name it). Registering an id again replaces its name.
  absl::Status RegisterWorker(absl::string_view worker_id, absl::string_view name, int64_t now_ms);
  // The lease owner's report of the task's stage (opaque bytes; the service
  // keeps a serialized StageFinished), kept with the task for Task::
  // stage_finished. FAILED_PRECONDITION unless the task is leased by
  // `worker`. Does not touch updated_ms.
  absl::Status SetStageFinished(absl::string_view task_id, absl::string_view worker, absl::string_view report);

  absl::StatusOr<Job> GetJob(absl::string_view job_id);
  // The client's jobs, oldest first.
  absl::StatusOr<std::vector<Job>> ListJobs(absl::string_view client);
  // Every client's jobs, oldest first (an admin's ListJobs).
  absl::StatusOr<std::vector<Job>> ListAllJobs();
  // The job's tasks, in creation order.
  absl::StatusOr<std::vector<Task>> TasksOfJob(absl::string_view job_id);
  absl::StatusOr<Task> GetTask(absl::string_view task_id);

 private:
  JobStore(std::unique_ptr<SqliteDb> db, JobStoreOptions options) : db_(std::move(db)), options_(options) {}

  // Helpers run with mu_ held, inside a transaction where they write.
  absl::StatusOr<Job> GetJobLocked(absl::string_view job_id);
  absl::StatusOr<Task> GetTaskLocked(absl::string_view task_id);
  // Fills task.depends_on from task_deps.
  absl::Status LoadDependencies(Task& task);
  // Inserts a queued task (job checked by the caller). `batch` holds the ids
  // of the follow-ups added so far in the same call, for FollowUpRef.
  absl::StatusOr<std::string> InsertTaskLocked(const NewTask& task, const std::optional<std::string>& added_by,
                                               const std::vector<std::string>& batch, int64_t now_ms);
  // Fails, with an error naming `failed`, the tasks depending on it
  // (transitively) that are not finished yet.
  absl::Status FailDependents(const Task& failed, int64_t now_ms);
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
