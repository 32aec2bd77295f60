#include "server/store/job_store.h"

#include <algorithm>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "server/store/digest.h"
#include "server/store/schema.h"

namespace mvbrdf::store {
namespace {

constexpr const char* kJobColumns =
    "id, client, state, scene_hash, request, error, created_ms, updated_ms, sealed";
// tasks.depends_on is unused since schema version 2 (see task_deps).
constexpr const char* kTaskColumns =
    "id, job_id, kind, key, added_by, state, attempts, max_attempts, lease_owner, lease_expires_ms, result, "
    "error, created_ms, updated_ms, started_ms, samples_from_cache, worker_faults, stage_finished, "
    "(SELECT name FROM workers WHERE workers.id = tasks.lease_owner)";
constexpr absl::string_view kFollowUpRefPrefix = "follow_up:";

absl::StatusOr<Job> ReadJob(const Statement& row) {
  Job job;
  job.id = row.ColumnText(0);
  job.client = row.ColumnText(1);
  MVBRDF_ASSIGN_OR_RETURN(job.state, ParseJobState(row.ColumnText(2)));
  job.scene_hash = row.ColumnText(3);
  job.request = row.ColumnBlob(4);
  job.error = row.ColumnText(5);
  job.created_ms = row.ColumnInt64(6);
  job.updated_ms = row.ColumnInt64(7);
  job.sealed = row.ColumnInt64(8) != 0;
  return job;
}

absl::StatusOr<Task> ReadTask(const Statement& row) {
  Task task;
  task.id = row.ColumnText(0);
  task.job_id = row.ColumnText(1);
  task.kind = row.ColumnText(2);
  task.key = row.ColumnText(3);
  if (!row.ColumnIsNull(4)) task.added_by = row.ColumnText(4);
  MVBRDF_ASSIGN_OR_RETURN(task.state, ParseTaskState(row.ColumnText(5)));
  task.attempts = static_cast<int>(row.ColumnInt64(6));
  task.max_attempts = static_cast<int>(row.ColumnInt64(7));
  task.lease_owner = row.ColumnText(8);
  task.lease_expires_ms = row.ColumnIsNull(9) ? 0 : row.ColumnInt64(9);
  if (!row.ColumnIsNull(10)) task.result = row.ColumnBlob(10);
  task.error = row.ColumnText(11);
  task.created_ms = row.ColumnInt64(12);
  task.updated_ms = row.ColumnInt64(13);
  task.started_ms = row.ColumnInt64(14);
  task.samples_from_cache = row.ColumnInt64(15) != 0;
  task.worker_faults = static_cast<int>(row.ColumnInt64(16));
  if (!row.ColumnIsNull(17)) task.stage_finished = row.ColumnBlob(17);
  if (!row.ColumnIsNull(18)) task.worker_name = row.ColumnText(18);
  return task;
}

}  // namespace

std::string FollowUpRef(int index) { return absl::StrCat(kFollowUpRefPrefix, index); }

// --- States -----------------------------------------------------------------

absl::string_view JobStateName(JobState state) {
  switch (state) {
    case JobState::kQueued: return "queued";
    case JobState::kRunning: return "running";
    case JobState::kSucceeded: return "succeeded";
    case JobState::kFailed: return "failed";
    case JobState::kCancelled: return "cancelled";
  }
  return "unknown";
}

absl::string_view TaskStateName(TaskState state) {
  switch (state) {
    case TaskState::kQueued: return "queued";
    case TaskState::kLeased: return "leased";
    case TaskState::kDone: return "done";
    case TaskState::kFailed: return "failed";
    case TaskState::kCancelled: return "cancelled";
  }
  return "unknown";
}

absl::StatusOr<JobState> ParseJobState(absl::string_view name) {
  for (JobState state : {JobState::kQueued, JobState::kRunning, JobState::kSucceeded, JobState::kFailed,
                         JobState::kCancelled}) {
    if (JobStateName(state) == name) return state;
  }
  return absl::DataLossError(absl::StrCat("jobs.state: unknown state '", name, "'"));
}

absl::StatusOr<TaskState> ParseTaskState(absl::string_view name) {
  for (TaskState state : {TaskState::kQueued, TaskState::kLeased, TaskState::kDone, TaskState::kFailed,
                          TaskState::kCancelled}) {
    if (TaskStateName(state) == name) return state;
  }
  return absl::DataLossError(absl::StrCat("tasks.state: unknown state '", name, "'"));
}

bool IsFinal(JobState state) {
  return state == JobState::kSucceeded || state == JobState::kFailed || state == JobState::kCancelled;
}

absl::Status JobStoreOptions::Check() const {
  if (default_max_attempts < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("JobStoreOptions.default_max_attempts: must be >= 1, got ", default_max_attempts));
  }
  return absl::OkStatus();
}

// --- JobStore ---------------------------------------------------------------

absl::StatusOr<std::unique_ptr<JobStore>> JobStore::Open(const std::filesystem::path& path,
                                                         JobStoreOptions options) {
  MVBRDF_RETURN_IF_ERROR(options.Check());
  MVBRDF_ASSIGN_OR_RETURN(std::unique_ptr<SqliteDb> db, OpenStoreDb(path));
  return std::unique_ptr<JobStore>(new JobStore(std::move(db), options));
}

absl::StatusOr<std::string> JobStore::CreateJob(const NewJob& job, int64_t now_ms) {
  MVBRDF_ASSIGN_OR_RETURN(std::string id, RandomId128());
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(
      Statement insert,
      Statement::Prepare(*db_,
                         "INSERT INTO jobs (id, client, state, scene_hash, request, created_ms, updated_ms) "
                         "VALUES (?1, ?2, 'queued', ?3, ?4, ?5, ?5)"));
  MVBRDF_RETURN_IF_ERROR(insert.BindText(1, id));
  MVBRDF_RETURN_IF_ERROR(insert.BindText(2, job.client));
  MVBRDF_RETURN_IF_ERROR(insert.BindText(3, job.scene_hash));
  MVBRDF_RETURN_IF_ERROR(insert.BindBlob(4, job.request));
  MVBRDF_RETURN_IF_ERROR(insert.BindInt64(5, now_ms));
  MVBRDF_RETURN_IF_ERROR(insert.Run());
  return id;
}

absl::StatusOr<std::string> JobStore::AddTask(const NewTask& task, int64_t now_ms) {
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(Transaction transaction, Transaction::Begin(*db_));
  MVBRDF_ASSIGN_OR_RETURN(Job job, GetJobLocked(task.job_id));
  if (IsFinal(job.state)) {
    return absl::FailedPreconditionError(
        absl::StrCat("AddTask: job ", job.id, " is ", JobStateName(job.state), "; it takes no more tasks"));
  }
  if (job.sealed) {
    return absl::FailedPreconditionError(absl::StrCat(
        "AddTask: job ", job.id, " is sealed; only a completing task may add follow-ups (CompleteTask)"));
  }
  MVBRDF_ASSIGN_OR_RETURN(std::string id, InsertTaskLocked(task, std::nullopt, {}, now_ms));
  MVBRDF_RETURN_IF_ERROR(transaction.Commit());
  return id;
}

absl::Status JobStore::SealJob(absl::string_view job_id, int64_t now_ms) {
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(Transaction transaction, Transaction::Begin(*db_));
  MVBRDF_ASSIGN_OR_RETURN(Job job, GetJobLocked(job_id));
  if (job.sealed) return absl::OkStatus();  // a retried call
  if (IsFinal(job.state)) {
    return absl::FailedPreconditionError(
        absl::StrCat("SealJob: job ", job_id, " is ", JobStateName(job.state)));
  }
  MVBRDF_ASSIGN_OR_RETURN(Statement count,
                          Statement::Prepare(*db_, "SELECT COUNT(*) FROM tasks WHERE job_id = ?1"));
  MVBRDF_RETURN_IF_ERROR(count.BindText(1, job_id));
  MVBRDF_ASSIGN_OR_RETURN(StepResult step, count.Step());
  if (step != StepResult::kRow) return absl::InternalError("SealJob: COUNT returned no row");
  if (count.ColumnInt64(0) == 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("SealJob: job ", job_id, " has no tasks; sealed, it could never finish"));
  }
  MVBRDF_ASSIGN_OR_RETURN(
      Statement seal, Statement::Prepare(*db_, "UPDATE jobs SET sealed = 1, updated_ms = ?2 WHERE id = ?1"));
  MVBRDF_RETURN_IF_ERROR(seal.BindText(1, job_id));
  MVBRDF_RETURN_IF_ERROR(seal.BindInt64(2, now_ms));
  MVBRDF_RETURN_IF_ERROR(seal.Run());
  MVBRDF_RETURN_IF_ERROR(RefreshJobState(job_id, now_ms));
  return transaction.Commit();
}

absl::StatusOr<std::optional<Task>> JobStore::LeaseTask(absl::string_view worker, int64_t now_ms,
                                                        int64_t lease_ms, const std::vector<std::string>& kinds) {
  if (lease_ms <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("LeaseTask.lease_ms: must be > 0, got ", lease_ms));
  }
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(Transaction transaction, Transaction::Begin(*db_));
  MVBRDF_RETURN_IF_ERROR(FailExpiredLeases(now_ms));

  // The kind filter adds one placeholder per kind; values are still bound.
  std::string sql = absl::StrCat(
      "SELECT t.id FROM tasks t JOIN jobs j ON j.id = t.job_id "
      "WHERE j.state IN ('queued', 'running') AND ("
      "  (t.state = 'queued' AND NOT EXISTS ("
      "     SELECT 1 FROM task_deps e JOIN tasks d ON d.id = e.depends_on"
      "     WHERE e.task_id = t.id AND d.state <> 'done'))"
      "  OR (t.state = 'leased' AND t.lease_expires_ms <= ?1))");
  if (!kinds.empty()) {
    sql += " AND t.kind IN (";
    for (size_t i = 0; i < kinds.size(); ++i) absl::StrAppend(&sql, i == 0 ? "" : ", ", "?", i + 2);
    sql += ")";
  }
  sql += " ORDER BY t.created_ms, t.rowid LIMIT 1";
  MVBRDF_ASSIGN_OR_RETURN(Statement select, Statement::Prepare(*db_, sql));
  MVBRDF_RETURN_IF_ERROR(select.BindInt64(1, now_ms));
  for (size_t i = 0; i < kinds.size(); ++i) {
    MVBRDF_RETURN_IF_ERROR(select.BindText(static_cast<int>(i) + 2, kinds[i]));
  }
  MVBRDF_ASSIGN_OR_RETURN(StepResult step, select.Step());
  if (step == StepResult::kDone) {
    MVBRDF_RETURN_IF_ERROR(transaction.Commit());  // keeps the expiry failures
    return std::optional<Task>();
  }
  const std::string task_id = select.ColumnText(0);

  MVBRDF_ASSIGN_OR_RETURN(
      Statement lease,
      Statement::Prepare(*db_,
                         "UPDATE tasks SET state = 'leased', lease_owner = ?2, lease_expires_ms = ?3, "
                         "attempts = attempts + 1, started_ms = ?4, updated_ms = ?4 WHERE id = ?1"));
  MVBRDF_RETURN_IF_ERROR(lease.BindText(1, task_id));
  MVBRDF_RETURN_IF_ERROR(lease.BindText(2, worker));
  MVBRDF_RETURN_IF_ERROR(lease.BindInt64(3, now_ms + lease_ms));
  MVBRDF_RETURN_IF_ERROR(lease.BindInt64(4, now_ms));
  MVBRDF_RETURN_IF_ERROR(lease.Run());
  MVBRDF_ASSIGN_OR_RETURN(Task task, GetTaskLocked(task_id));
  MVBRDF_RETURN_IF_ERROR(RefreshJobState(task.job_id, now_ms));
  MVBRDF_RETURN_IF_ERROR(transaction.Commit());
  return std::optional<Task>(std::move(task));
}

absl::Status JobStore::RenewLease(absl::string_view task_id, absl::string_view worker, int64_t now_ms,
                                  int64_t lease_ms) {
  if (lease_ms <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("RenewLease.lease_ms: must be > 0, got ", lease_ms));
  }
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(Transaction transaction, Transaction::Begin(*db_));
  MVBRDF_RETURN_IF_ERROR(GetLeasedTaskOf(task_id, worker, "RenewLease").status());
  MVBRDF_ASSIGN_OR_RETURN(
      Statement renew,
      Statement::Prepare(*db_, "UPDATE tasks SET lease_expires_ms = ?2, updated_ms = ?3 WHERE id = ?1"));
  MVBRDF_RETURN_IF_ERROR(renew.BindText(1, task_id));
  MVBRDF_RETURN_IF_ERROR(renew.BindInt64(2, now_ms + lease_ms));
  MVBRDF_RETURN_IF_ERROR(renew.BindInt64(3, now_ms));
  MVBRDF_RETURN_IF_ERROR(renew.Run());
  return transaction.Commit();
}

absl::Status JobStore::CompleteTask(absl::string_view task_id, absl::string_view worker, absl::string_view result,
                                    int64_t now_ms) {
  return CompleteTask(task_id, worker, result, now_ms, {}).status();
}

absl::StatusOr<std::vector<std::string>> JobStore::CompleteTask(absl::string_view task_id,
                                                                absl::string_view worker,
                                                                absl::string_view result, int64_t now_ms,
                                                                const std::vector<NewTask>& follow_ups) {
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(Transaction transaction, Transaction::Begin(*db_));
  MVBRDF_ASSIGN_OR_RETURN(Task task, GetTaskLocked(task_id));
  if (task.state == TaskState::kDone && task.lease_owner == worker) {
    // A retried completion (the worker did not see our answer): its
    // follow-ups were added with the first one.
    if (!task.result.has_value() || *task.result != result) {
      return absl::FailedPreconditionError(
          absl::StrCat("CompleteTask: task ", task_id, " is already done with a different result"));
    }
    MVBRDF_ASSIGN_OR_RETURN(
        Statement select,
        Statement::Prepare(*db_, "SELECT id FROM tasks WHERE added_by = ?1 ORDER BY created_ms, rowid"));
    MVBRDF_RETURN_IF_ERROR(select.BindText(1, task_id));
    std::vector<std::string> added;
    MVBRDF_RETURN_IF_ERROR(select.ForEachRow([&]() -> absl::Status {
      added.push_back(select.ColumnText(0));
      return absl::OkStatus();
    }));
    return added;
  }
  MVBRDF_RETURN_IF_ERROR(GetLeasedTaskOf(task_id, worker, "CompleteTask").status());
  MVBRDF_ASSIGN_OR_RETURN(
      Statement complete,
      Statement::Prepare(*db_,
                         "UPDATE tasks SET state = 'done', result = ?2, lease_expires_ms = NULL, error = '', "
                         "updated_ms = ?3 WHERE id = ?1"));
  MVBRDF_RETURN_IF_ERROR(complete.BindText(1, task_id));
  MVBRDF_RETURN_IF_ERROR(complete.BindBlob(2, result));
  MVBRDF_RETURN_IF_ERROR(complete.BindInt64(3, now_ms));
  MVBRDF_RETURN_IF_ERROR(complete.Run());
  std::vector<std::string> added;
  for (size_t i = 0; i < follow_ups.size(); ++i) {
    NewTask follow_up = follow_ups[i];
    if (follow_up.job_id.empty()) follow_up.job_id = task.job_id;
    if (follow_up.job_id != task.job_id) {
      return absl::InvalidArgumentError(absl::StrCat("CompleteTask.follow_ups[", i, "].job_id: '", follow_up.job_id,
                                                     "' is not the job of task ", task_id, " (", task.job_id,
                                                     ")"));
    }
    MVBRDF_ASSIGN_OR_RETURN(std::string id, InsertTaskLocked(follow_up, task.id, added, now_ms));
    added.push_back(std::move(id));
  }
  MVBRDF_RETURN_IF_ERROR(RefreshJobState(task.job_id, now_ms));
  MVBRDF_RETURN_IF_ERROR(transaction.Commit());
  return added;
}

absl::Status JobStore::FailTask(absl::string_view task_id, absl::string_view worker, absl::string_view error,
                                int64_t now_ms, bool permanent, bool worker_fault) {
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(Transaction transaction, Transaction::Begin(*db_));
  MVBRDF_ASSIGN_OR_RETURN(Task task, GetLeasedTaskOf(task_id, worker, "FailTask"));
  if (worker_fault && !permanent && task.worker_faults + 1 < 2 * task.max_attempts) {
    // Not the job's fault: back to the queue, the attempt given back.
    MVBRDF_ASSIGN_OR_RETURN(
        Statement requeue,
        Statement::Prepare(*db_,
                           "UPDATE tasks SET state = 'queued', lease_expires_ms = NULL, error = ?2, updated_ms = ?3, "
                           "attempts = MAX(attempts - 1, 0), worker_faults = worker_faults + 1 WHERE id = ?1"));
    MVBRDF_RETURN_IF_ERROR(requeue.BindText(1, task_id));
    MVBRDF_RETURN_IF_ERROR(requeue.BindText(2, error));
    MVBRDF_RETURN_IF_ERROR(requeue.BindInt64(3, now_ms));
    MVBRDF_RETURN_IF_ERROR(requeue.Run());
    MVBRDF_RETURN_IF_ERROR(RefreshJobState(task.job_id, now_ms));
    return transaction.Commit();
  }
  if (worker_fault && !permanent) {
    // The last of its workers' own failures: the job ends, saying so.
    MVBRDF_ASSIGN_OR_RETURN(
        Statement count, Statement::Prepare(*db_, "UPDATE tasks SET worker_faults = worker_faults + 1 WHERE id = ?1"));
    MVBRDF_RETURN_IF_ERROR(count.BindText(1, task_id));
    MVBRDF_RETURN_IF_ERROR(count.Run());
  }
  const bool final = permanent || worker_fault || task.attempts >= task.max_attempts;
  MVBRDF_ASSIGN_OR_RETURN(
      Statement fail,
      Statement::Prepare(*db_,
                         "UPDATE tasks SET state = ?2, lease_expires_ms = NULL, error = ?3, updated_ms = ?4 "
                         "WHERE id = ?1"));
  MVBRDF_RETURN_IF_ERROR(fail.BindText(1, task_id));
  MVBRDF_RETURN_IF_ERROR(fail.BindText(2, TaskStateName(final ? TaskState::kFailed : TaskState::kQueued)));
  MVBRDF_RETURN_IF_ERROR(fail.BindText(3, error));
  MVBRDF_RETURN_IF_ERROR(fail.BindInt64(4, now_ms));
  MVBRDF_RETURN_IF_ERROR(fail.Run());
  if (final) {
    MVBRDF_RETURN_IF_ERROR(FailDependents(task, now_ms));
    MVBRDF_RETURN_IF_ERROR(FailJobLocked(
        task.job_id,
        worker_fault && !permanent
            ? absl::StrCat("task ", task.kind, " '", task.key, "' failed ", task.worker_faults + 1,
                           " times on workers whose own environment failed; the last: ", error)
        : permanent && task.attempts < task.max_attempts
            ? absl::StrCat("task ", task.kind, " '", task.key, "' failed: ", error)
            : absl::StrCat("task ", task.kind, " '", task.key, "' failed after ", task.attempts, " attempts: ", error),
        now_ms));
  } else {
    MVBRDF_RETURN_IF_ERROR(RefreshJobState(task.job_id, now_ms));
  }
  return transaction.Commit();
}

absl::Status JobStore::RedoDependency(absl::string_view task_id, absl::string_view worker,
                                      absl::string_view dependency_id, absl::string_view reason, int64_t now_ms) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    MVBRDF_ASSIGN_OR_RETURN(Transaction transaction, Transaction::Begin(*db_));
    MVBRDF_ASSIGN_OR_RETURN(Task task, GetLeasedTaskOf(task_id, worker, "RedoDependency"));
    if (std::find(task.depends_on.begin(), task.depends_on.end(), dependency_id) == task.depends_on.end()) {
      return absl::InvalidArgumentError(absl::StrCat("RedoDependency: task ", dependency_id,
                                                     " is not a dependency of task ", task_id));
    }
    MVBRDF_ASSIGN_OR_RETURN(Task dependency, GetTaskLocked(dependency_id));
    const bool exhausted = dependency.state == TaskState::kDone && dependency.attempts >= dependency.max_attempts;
    if (!exhausted) {
      if (dependency.state == TaskState::kDone) {
        MVBRDF_ASSIGN_OR_RETURN(
            Statement redo,
            Statement::Prepare(*db_,
                               "UPDATE tasks SET state = 'queued', result = NULL, stage_finished = NULL, "
                               "lease_expires_ms = NULL, samples_from_cache = 0, error = ?2, updated_ms = ?3 "
                               "WHERE id = ?1"));
        MVBRDF_RETURN_IF_ERROR(redo.BindText(1, dependency_id));
        MVBRDF_RETURN_IF_ERROR(redo.BindText(2, reason));
        MVBRDF_RETURN_IF_ERROR(redo.BindInt64(3, now_ms));
        MVBRDF_RETURN_IF_ERROR(redo.Run());
      }
      MVBRDF_ASSIGN_OR_RETURN(
          Statement requeue,
          Statement::Prepare(*db_,
                             "UPDATE tasks SET state = 'queued', lease_expires_ms = NULL, "
                             "attempts = MAX(attempts - 1, 0), updated_ms = ?2 WHERE id = ?1"));
      MVBRDF_RETURN_IF_ERROR(requeue.BindText(1, task_id));
      MVBRDF_RETURN_IF_ERROR(requeue.BindInt64(2, now_ms));
      MVBRDF_RETURN_IF_ERROR(requeue.Run());
      MVBRDF_RETURN_IF_ERROR(RefreshJobState(task.job_id, now_ms));
      return transaction.Commit();
    }
  }
  return FailTask(task_id, worker,
                  absl::StrCat(reason, " (task ", dependency_id, " already ran ", "its maximum number of times)"),
                  now_ms, /*permanent=*/true);
}

absl::Status JobStore::CancelJob(absl::string_view job_id, int64_t now_ms) {
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(Transaction transaction, Transaction::Begin(*db_));
  MVBRDF_ASSIGN_OR_RETURN(Job job, GetJobLocked(job_id));
  if (job.state == JobState::kCancelled) return absl::OkStatus();
  if (IsFinal(job.state)) {
    return absl::FailedPreconditionError(
        absl::StrCat("CancelJob: job ", job_id, " already ", JobStateName(job.state)));
  }
  MVBRDF_RETURN_IF_ERROR(SetJobState(job_id, JobState::kCancelled, "", now_ms));
  return transaction.Commit();
}

absl::Status JobStore::SetSamplesFromCache(absl::string_view task_id, bool from_cache) {
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(Statement update,
                          Statement::Prepare(*db_, "UPDATE tasks SET samples_from_cache = ?2 WHERE id = ?1"));
  MVBRDF_RETURN_IF_ERROR(update.BindText(1, task_id));
  MVBRDF_RETURN_IF_ERROR(update.BindInt64(2, from_cache ? 1 : 0));
  MVBRDF_RETURN_IF_ERROR(update.Run());
  if (db_->Changes() == 0) return absl::NotFoundError(absl::StrCat("task ", task_id, ": no such task"));
  return absl::OkStatus();
}

absl::Status JobStore::RegisterWorker(absl::string_view worker_id, absl::string_view name, int64_t now_ms) {
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(
      Statement insert,
      Statement::Prepare(*db_, "INSERT OR REPLACE INTO workers (id, name, registered_ms) VALUES (?1, ?2, ?3)"));
  MVBRDF_RETURN_IF_ERROR(insert.BindText(1, worker_id));
  MVBRDF_RETURN_IF_ERROR(insert.BindText(2, name));
  MVBRDF_RETURN_IF_ERROR(insert.BindInt64(3, now_ms));
  return insert.Run();
}

absl::Status JobStore::SetStageFinished(absl::string_view task_id, absl::string_view worker,
                                        absl::string_view report) {
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(
      Statement update,
      Statement::Prepare(*db_, "UPDATE tasks SET stage_finished = ?3 WHERE id = ?1 AND state = 'leased' "
                               "AND lease_owner = ?2"));
  MVBRDF_RETURN_IF_ERROR(update.BindText(1, task_id));
  MVBRDF_RETURN_IF_ERROR(update.BindText(2, worker));
  MVBRDF_RETURN_IF_ERROR(update.BindBlob(3, report));
  MVBRDF_RETURN_IF_ERROR(update.Run());
  if (db_->Changes() == 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("SetStageFinished: task ", task_id, " is not leased by worker ", worker));
  }
  return absl::OkStatus();
}

absl::StatusOr<Job> JobStore::GetJob(absl::string_view job_id) {
  std::lock_guard<std::mutex> lock(mu_);
  return GetJobLocked(job_id);
}

absl::StatusOr<Task> JobStore::GetTask(absl::string_view task_id) {
  std::lock_guard<std::mutex> lock(mu_);
  return GetTaskLocked(task_id);
}

absl::StatusOr<std::vector<Job>> JobStore::ListJobs(absl::string_view client) {
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(
      Statement select,
      Statement::Prepare(*db_, absl::StrCat("SELECT ", kJobColumns,
                                            " FROM jobs WHERE client = ?1 ORDER BY created_ms, rowid")));
  MVBRDF_RETURN_IF_ERROR(select.BindText(1, client));
  std::vector<Job> jobs;
  MVBRDF_RETURN_IF_ERROR(select.ForEachRow([&]() -> absl::Status {
    MVBRDF_ASSIGN_OR_RETURN(Job job, ReadJob(select));
    jobs.push_back(std::move(job));
    return absl::OkStatus();
  }));
  return jobs;
}

absl::StatusOr<std::vector<Job>> JobStore::ListAllJobs() {
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(
      Statement select,
      Statement::Prepare(*db_, absl::StrCat("SELECT ", kJobColumns,
                                            " FROM jobs ORDER BY created_ms, rowid")));
  std::vector<Job> jobs;
  MVBRDF_RETURN_IF_ERROR(select.ForEachRow([&]() -> absl::Status {
    MVBRDF_ASSIGN_OR_RETURN(Job job, ReadJob(select));
    jobs.push_back(std::move(job));
    return absl::OkStatus();
  }));
  return jobs;
}

absl::StatusOr<std::vector<Task>> JobStore::TasksOfJob(absl::string_view job_id) {
  std::lock_guard<std::mutex> lock(mu_);
  MVBRDF_ASSIGN_OR_RETURN(
      Statement select,
      Statement::Prepare(*db_, absl::StrCat("SELECT ", kTaskColumns,
                                            " FROM tasks WHERE job_id = ?1 ORDER BY created_ms, rowid")));
  MVBRDF_RETURN_IF_ERROR(select.BindText(1, job_id));
  std::vector<Task> tasks;
  MVBRDF_RETURN_IF_ERROR(select.ForEachRow([&]() -> absl::Status {
    MVBRDF_ASSIGN_OR_RETURN(Task task, ReadTask(select));
    tasks.push_back(std::move(task));
    return absl::OkStatus();
  }));
  for (Task& task : tasks) MVBRDF_RETURN_IF_ERROR(LoadDependencies(task));
  return tasks;
}

// --- Helpers (mu_ held) -----------------------------------------------------

absl::StatusOr<Job> JobStore::GetJobLocked(absl::string_view job_id) {
  MVBRDF_ASSIGN_OR_RETURN(Statement select,
                          Statement::Prepare(*db_, absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE id = ?1")));
  MVBRDF_RETURN_IF_ERROR(select.BindText(1, job_id));
  MVBRDF_ASSIGN_OR_RETURN(StepResult step, select.Step());
  if (step == StepResult::kDone) return absl::NotFoundError(absl::StrCat("job ", job_id, ": no such job"));
  return ReadJob(select);
}

absl::StatusOr<Task> JobStore::GetTaskLocked(absl::string_view task_id) {
  MVBRDF_ASSIGN_OR_RETURN(
      Statement select, Statement::Prepare(*db_, absl::StrCat("SELECT ", kTaskColumns, " FROM tasks WHERE id = ?1")));
  MVBRDF_RETURN_IF_ERROR(select.BindText(1, task_id));
  MVBRDF_ASSIGN_OR_RETURN(StepResult step, select.Step());
  if (step == StepResult::kDone) return absl::NotFoundError(absl::StrCat("task ", task_id, ": no such task"));
  MVBRDF_ASSIGN_OR_RETURN(Task task, ReadTask(select));
  MVBRDF_RETURN_IF_ERROR(LoadDependencies(task));
  return task;
}

absl::Status JobStore::LoadDependencies(Task& task) {
  MVBRDF_ASSIGN_OR_RETURN(
      Statement select,
      Statement::Prepare(*db_, "SELECT depends_on FROM task_deps WHERE task_id = ?1 ORDER BY rowid"));
  MVBRDF_RETURN_IF_ERROR(select.BindText(1, task.id));
  task.depends_on.clear();
  MVBRDF_RETURN_IF_ERROR(select.ForEachRow([&]() -> absl::Status {
    task.depends_on.push_back(select.ColumnText(0));
    return absl::OkStatus();
  }));
  return absl::OkStatus();
}

absl::StatusOr<std::string> JobStore::InsertTaskLocked(const NewTask& task,
                                                       const std::optional<std::string>& added_by,
                                                       const std::vector<std::string>& batch, int64_t now_ms) {
  const int max_attempts = task.max_attempts > 0 ? task.max_attempts : options_.default_max_attempts;
  // Resolve and check every dependency before writing anything.
  std::vector<std::string> dependencies;
  for (const std::string& dependency : task.depends_on) {
    std::string id = dependency;
    if (absl::StartsWith(dependency, kFollowUpRefPrefix)) {
      int index = -1;
      if (!absl::SimpleAtoi(absl::string_view(dependency).substr(kFollowUpRefPrefix.size()), &index) || index < 0 ||
          static_cast<size_t>(index) >= batch.size()) {
        return absl::InvalidArgumentError(absl::StrCat("NewTask.depends_on: '", dependency,
                                                       "' is not an earlier follow-up of the same call (",
                                                       batch.size(), " so far)"));
      }
      id = batch[static_cast<size_t>(index)];
    } else {
      absl::StatusOr<Task> found = GetTaskLocked(dependency);
      if (!found.ok() || found->job_id != task.job_id) {
        return absl::InvalidArgumentError(
            absl::StrCat("NewTask.depends_on: '", dependency, "' is not a task of job ", task.job_id));
      }
    }
    if (std::find(dependencies.begin(), dependencies.end(), id) == dependencies.end()) {
      dependencies.push_back(std::move(id));
    }
  }

  MVBRDF_ASSIGN_OR_RETURN(std::string id, RandomId128());
  MVBRDF_ASSIGN_OR_RETURN(
      Statement insert,
      Statement::Prepare(*db_,
                         "INSERT INTO tasks (id, job_id, kind, key, added_by, state, max_attempts, created_ms, "
                         "updated_ms) VALUES (?1, ?2, ?3, ?4, ?5, 'queued', ?6, ?7, ?7)"));
  MVBRDF_RETURN_IF_ERROR(insert.BindText(1, id));
  MVBRDF_RETURN_IF_ERROR(insert.BindText(2, task.job_id));
  MVBRDF_RETURN_IF_ERROR(insert.BindText(3, task.kind));
  MVBRDF_RETURN_IF_ERROR(insert.BindText(4, task.key));
  if (added_by.has_value()) {
    MVBRDF_RETURN_IF_ERROR(insert.BindText(5, *added_by));
  } else {
    MVBRDF_RETURN_IF_ERROR(insert.BindNull(5));
  }
  MVBRDF_RETURN_IF_ERROR(insert.BindInt64(6, max_attempts));
  MVBRDF_RETURN_IF_ERROR(insert.BindInt64(7, now_ms));
  MVBRDF_RETURN_IF_ERROR(insert.Run());
  MVBRDF_ASSIGN_OR_RETURN(Statement insert_dependency,
                          Statement::Prepare(*db_, "INSERT INTO task_deps (task_id, depends_on) VALUES (?1, ?2)"));
  for (const std::string& dependency : dependencies) {
    MVBRDF_RETURN_IF_ERROR(insert_dependency.Reset());
    MVBRDF_RETURN_IF_ERROR(insert_dependency.BindText(1, id));
    MVBRDF_RETURN_IF_ERROR(insert_dependency.BindText(2, dependency));
    MVBRDF_RETURN_IF_ERROR(insert_dependency.Run());
  }
  return id;
}

absl::Status JobStore::FailDependents(const Task& failed, int64_t now_ms) {
  MVBRDF_ASSIGN_OR_RETURN(
      Statement fail,
      Statement::Prepare(*db_,
                         "WITH RECURSIVE dependents (id) AS ("
                         "  SELECT task_id FROM task_deps WHERE depends_on = ?1"
                         "  UNION SELECT e.task_id FROM task_deps e JOIN dependents d ON e.depends_on = d.id) "
                         "UPDATE tasks SET state = 'failed', lease_expires_ms = NULL, error = ?2, updated_ms = ?3 "
                         "WHERE id IN (SELECT id FROM dependents) AND state IN ('queued', 'leased')"));
  MVBRDF_RETURN_IF_ERROR(fail.BindText(1, failed.id));
  MVBRDF_RETURN_IF_ERROR(
      fail.BindText(2, absl::StrCat("dependency ", failed.kind, " '", failed.key, "' (", failed.id, ") failed")));
  MVBRDF_RETURN_IF_ERROR(fail.BindInt64(3, now_ms));
  return fail.Run();
}

absl::StatusOr<Task> JobStore::GetLeasedTaskOf(absl::string_view task_id, absl::string_view worker,
                                               absl::string_view operation) {
  MVBRDF_ASSIGN_OR_RETURN(Task task, GetTaskLocked(task_id));
  if (task.state != TaskState::kLeased) {
    return absl::FailedPreconditionError(absl::StrCat(operation, ": task ", task_id, " is ",
                                                      TaskStateName(task.state), ", not leased"));
  }
  if (task.lease_owner != worker) {
    return absl::FailedPreconditionError(absl::StrCat(operation, ": task ", task_id, " is leased by '",
                                                      task.lease_owner, "', not by '", worker, "'"));
  }
  return task;
}

absl::Status JobStore::SetJobState(absl::string_view job_id, JobState state, absl::string_view error,
                                   int64_t now_ms) {
  MVBRDF_ASSIGN_OR_RETURN(
      Statement update,
      Statement::Prepare(*db_, "UPDATE jobs SET state = ?2, error = ?3, updated_ms = ?4 WHERE id = ?1"));
  MVBRDF_RETURN_IF_ERROR(update.BindText(1, job_id));
  MVBRDF_RETURN_IF_ERROR(update.BindText(2, JobStateName(state)));
  MVBRDF_RETURN_IF_ERROR(update.BindText(3, error));
  MVBRDF_RETURN_IF_ERROR(update.BindInt64(4, now_ms));
  MVBRDF_RETURN_IF_ERROR(update.Run());
  if (state == JobState::kFailed || state == JobState::kCancelled) {
    // The rest of the job will never be used.
    MVBRDF_ASSIGN_OR_RETURN(
        Statement cancel,
        Statement::Prepare(*db_,
                           "UPDATE tasks SET state = 'cancelled', lease_expires_ms = NULL, updated_ms = ?2 "
                           "WHERE job_id = ?1 AND state IN ('queued', 'leased')"));
    MVBRDF_RETURN_IF_ERROR(cancel.BindText(1, job_id));
    MVBRDF_RETURN_IF_ERROR(cancel.BindInt64(2, now_ms));
    MVBRDF_RETURN_IF_ERROR(cancel.Run());
  }
  return absl::OkStatus();
}

absl::Status JobStore::FailJobLocked(absl::string_view job_id, absl::string_view error, int64_t now_ms) {
  MVBRDF_ASSIGN_OR_RETURN(Job job, GetJobLocked(job_id));
  if (IsFinal(job.state)) return absl::OkStatus();
  return SetJobState(job_id, JobState::kFailed, error, now_ms);
}

absl::Status JobStore::FailExpiredLeases(int64_t now_ms) {
  // Expired leases with no attempt left: the worker died (or hung) on every
  // attempt, so the task is likely what kills it.
  MVBRDF_ASSIGN_OR_RETURN(
      Statement select,
      Statement::Prepare(*db_, absl::StrCat("SELECT ", kTaskColumns,
                                            " FROM tasks WHERE state = 'leased' AND lease_expires_ms <= ?1 "
                                            "AND attempts >= max_attempts")));
  MVBRDF_RETURN_IF_ERROR(select.BindInt64(1, now_ms));
  std::vector<Task> expired;
  MVBRDF_RETURN_IF_ERROR(select.ForEachRow([&]() -> absl::Status {
    MVBRDF_ASSIGN_OR_RETURN(Task task, ReadTask(select));
    expired.push_back(std::move(task));
    return absl::OkStatus();
  }));
  for (const Task& task : expired) {
    const std::string error = absl::StrCat("task ", task.kind, " '", task.key, "': lease of '", task.lease_owner,
                                           "' expired on the last of ", task.attempts, " attempts");
    MVBRDF_ASSIGN_OR_RETURN(
        Statement fail,
        Statement::Prepare(*db_,
                           "UPDATE tasks SET state = 'failed', lease_expires_ms = NULL, error = ?2, "
                           "updated_ms = ?3 WHERE id = ?1"));
    MVBRDF_RETURN_IF_ERROR(fail.BindText(1, task.id));
    MVBRDF_RETURN_IF_ERROR(fail.BindText(2, error));
    MVBRDF_RETURN_IF_ERROR(fail.BindInt64(3, now_ms));
    MVBRDF_RETURN_IF_ERROR(fail.Run());
    MVBRDF_RETURN_IF_ERROR(FailDependents(task, now_ms));
    MVBRDF_RETURN_IF_ERROR(FailJobLocked(task.job_id, error, now_ms));
  }
  return absl::OkStatus();
}

absl::Status JobStore::RefreshJobState(absl::string_view job_id, int64_t now_ms) {
  MVBRDF_ASSIGN_OR_RETURN(Job job, GetJobLocked(job_id));
  if (IsFinal(job.state)) return absl::OkStatus();
  MVBRDF_ASSIGN_OR_RETURN(
      Statement count,
      Statement::Prepare(*db_,
                         "SELECT COUNT(*), COALESCE(SUM(state = 'done'), 0), "
                         "COALESCE(SUM(state IN ('leased', 'done', 'failed') OR attempts > 0), 0) "
                         "FROM tasks WHERE job_id = ?1"));
  MVBRDF_RETURN_IF_ERROR(count.BindText(1, job_id));
  MVBRDF_ASSIGN_OR_RETURN(StepResult step, count.Step());
  if (step != StepResult::kRow) return absl::InternalError("RefreshJobState: COUNT returned no row");
  const int64_t total = count.ColumnInt64(0);
  const int64_t done = count.ColumnInt64(1);
  const int64_t started = count.ColumnInt64(2);
  JobState state = JobState::kQueued;
  if (job.sealed && total > 0 && done == total) {
    state = JobState::kSucceeded;
  } else if (started > 0) {
    state = JobState::kRunning;
  }
  if (state == job.state) return absl::OkStatus();
  return SetJobState(job_id, state, "", now_ms);
}

}  // namespace mvbrdf::store
