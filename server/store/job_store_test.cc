#include "server/store/job_store.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "server/store/schema.h"
#include "server/store/sqlite_db.h"
#include "server/store/test_dir.h"

namespace mvbrdf::store {
namespace {

constexpr int64_t kT0 = 1'700'000'000'000;  // an arbitrary "now", unix ms
constexpr int64_t kLeaseMs = 30'000;

std::unique_ptr<JobStore> OpenOrDie(const std::filesystem::path& path, JobStoreOptions options = {}) {
  auto store = JobStore::Open(path, options);
  EXPECT_TRUE(store.ok()) << store.status();
  return store.ok() ? std::move(*store) : nullptr;
}

std::string CreateJobOrDie(JobStore& store, const std::string& client = "alice") {
  auto id = store.CreateJob(NewJob{client, "scenehash", std::string("req\0bytes", 9)}, kT0);
  EXPECT_TRUE(id.ok()) << id.status();
  return id.ok() ? *id : "";
}

std::string AddTaskOrDie(JobStore& store, const std::string& job, const std::string& kind, const std::string& key,
                         std::optional<std::string> depends_on = std::nullopt, int64_t now_ms = kT0) {
  auto id = store.AddTask(NewTask{job, kind, key, std::move(depends_on), 0}, now_ms);
  EXPECT_TRUE(id.ok()) << id.status();
  return id.ok() ? *id : "";
}

Task LeaseOrDie(JobStore& store, const std::string& worker, int64_t now_ms) {
  auto task = store.LeaseTask(worker, now_ms, kLeaseMs);
  EXPECT_TRUE(task.ok()) << task.status();
  EXPECT_TRUE(task.ok() && task->has_value()) << "nothing leased";
  return task.ok() && task->has_value() ? **task : Task{};
}

JobState StateOf(JobStore& store, const std::string& job) {
  auto got = store.GetJob(job);
  EXPECT_TRUE(got.ok()) << got.status();
  return got.ok() ? got->state : JobState::kQueued;
}

void ExpectIntegrityOk(const std::filesystem::path& path) {
  auto db = SqliteDb::Open(path);
  ASSERT_TRUE(db.ok());
  for (const char* pragma : {"PRAGMA integrity_check", "PRAGMA foreign_key_check"}) {
    auto check = Statement::Prepare(**db, pragma);
    ASSERT_TRUE(check.ok());
    auto step = check->Step();
    ASSERT_TRUE(step.ok()) << step.status();
    if (std::string(pragma) == "PRAGMA integrity_check") {
      ASSERT_EQ(*step, StepResult::kRow);
      EXPECT_EQ(check->ColumnText(0), "ok");
    } else {
      EXPECT_EQ(*step, StepResult::kDone) << "foreign key violations";
    }
  }
}

TEST(JobStoreTest, JobSurvivesRestart) {
  TestDir dir;
  std::string job;
  std::string task;
  {
    auto store = OpenOrDie(dir.db());
    job = CreateJobOrDie(*store);
    EXPECT_EQ(job.size(), 32u);
    task = AddTaskOrDie(*store, job, "sweep", "key+fill");
    EXPECT_EQ(LeaseOrDie(*store, "w1", kT0).id, task);
  }
  auto store = OpenOrDie(dir.db());  // "server restart"
  auto got = store->GetJob(job);
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(got->client, "alice");
  EXPECT_EQ(got->scene_hash, "scenehash");
  EXPECT_EQ(got->request, std::string("req\0bytes", 9));
  EXPECT_EQ(got->state, JobState::kRunning);
  auto tasks = store->TasksOfJob(job);
  ASSERT_TRUE(tasks.ok());
  ASSERT_EQ(tasks->size(), 1u);
  EXPECT_EQ((*tasks)[0].state, TaskState::kLeased);
  EXPECT_EQ((*tasks)[0].lease_owner, "w1");
  // The lease still holds after the restart; the owner finishes the job.
  EXPECT_TRUE(store->CompleteTask(task, "w1", "result", kT0 + 10).ok());
  EXPECT_EQ(StateOf(*store, job), JobState::kRunning);  // not sealed yet
  ASSERT_TRUE(store->SealJob(job, kT0 + 11).ok());
  EXPECT_EQ(StateOf(*store, job), JobState::kSucceeded);
  auto jobs = store->ListJobs("alice");
  ASSERT_TRUE(jobs.ok());
  ASSERT_EQ(jobs->size(), 1u);
  EXPECT_EQ((*jobs)[0].id, job);
  auto none = store->ListJobs("bob");
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  EXPECT_EQ(store->GetJob("nope").status().code(), absl::StatusCode::kNotFound);
  store.reset();
  ExpectIntegrityOk(dir.db());
}

TEST(JobStoreTest, ExpiredLeaseGoesToAnotherWorker) {
  TestDir dir;
  auto store = OpenOrDie(dir.db());
  const std::string job = CreateJobOrDie(*store);
  const std::string task = AddTaskOrDie(*store, job, "sweep", "key");
  ASSERT_TRUE(store->SealJob(job, kT0).ok());
  Task first = LeaseOrDie(*store, "w1", kT0);
  EXPECT_EQ(first.attempts, 1);
  EXPECT_EQ(first.lease_expires_ms, kT0 + kLeaseMs);

  // Still leased just before expiry: nothing for w2.
  auto nothing = store->LeaseTask("w2", kT0 + kLeaseMs - 1, kLeaseMs);
  ASSERT_TRUE(nothing.ok());
  EXPECT_FALSE(nothing->has_value());

  Task second = LeaseOrDie(*store, "w2", kT0 + kLeaseMs);
  EXPECT_EQ(second.id, task);
  EXPECT_EQ(second.lease_owner, "w2");
  EXPECT_EQ(second.attempts, 2);

  // w1 lost the task: it can neither renew nor complete it.
  EXPECT_EQ(store->RenewLease(task, "w1", kT0 + kLeaseMs + 1, kLeaseMs).code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(store->CompleteTask(task, "w1", "late", kT0 + kLeaseMs + 1).code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_TRUE(store->CompleteTask(task, "w2", "r", kT0 + kLeaseMs + 2).ok());
  // A retried completion with the same result is fine; a different one is not.
  EXPECT_TRUE(store->CompleteTask(task, "w2", "r", kT0 + kLeaseMs + 3).ok());
  EXPECT_EQ(store->CompleteTask(task, "w2", "other", kT0 + kLeaseMs + 3).code(),
            absl::StatusCode::kFailedPrecondition);
  auto done = store->GetTask(task);
  ASSERT_TRUE(done.ok());
  EXPECT_EQ(done->state, TaskState::kDone);
  EXPECT_EQ(done->result, std::optional<std::string>("r"));
  EXPECT_EQ(StateOf(*store, job), JobState::kSucceeded);
}

TEST(JobStoreTest, RenewByOwnerOnly) {
  TestDir dir;
  auto store = OpenOrDie(dir.db());
  const std::string job = CreateJobOrDie(*store);
  const std::string task = AddTaskOrDie(*store, job, "sweep", "key");
  LeaseOrDie(*store, "w1", kT0);
  absl::Status refused = store->RenewLease(task, "w2", kT0 + 1000, kLeaseMs);
  EXPECT_EQ(refused.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(refused.message().find("leased by 'w1'"), absl::string_view::npos) << refused;

  // The owner's renewal keeps the task away from others past the first expiry.
  ASSERT_TRUE(store->RenewLease(task, "w1", kT0 + kLeaseMs - 1, kLeaseMs).ok());
  auto nothing = store->LeaseTask("w2", kT0 + kLeaseMs + 1, kLeaseMs);
  ASSERT_TRUE(nothing.ok());
  EXPECT_FALSE(nothing->has_value());
  EXPECT_EQ(store->RenewLease("unknown", "w1", kT0, kLeaseMs).code(), absl::StatusCode::kNotFound);
}

TEST(JobStoreTest, DependencyIsDoneBeforeTheDependentIsLeased) {
  TestDir dir;
  auto store = OpenOrDie(dir.db());
  const std::string job = CreateJobOrDie(*store);
  const std::string sweep = AddTaskOrDie(*store, job, "sweep", "all");
  const std::string texel = AddTaskOrDie(*store, job, "texel", "best", sweep);
  const std::string other_job = CreateJobOrDie(*store);
  const std::string other = AddTaskOrDie(*store, other_job, "sweep", "x", std::nullopt, kT0 + 5);

  EXPECT_EQ(LeaseOrDie(*store, "w1", kT0).id, sweep);
  // texel is older than `other` but waits for the sweep.
  EXPECT_EQ(LeaseOrDie(*store, "w2", kT0 + 1).id, other);
  auto nothing = store->LeaseTask("w3", kT0 + 2, kLeaseMs);
  ASSERT_TRUE(nothing.ok());
  EXPECT_FALSE(nothing->has_value());

  ASSERT_TRUE(store->CompleteTask(sweep, "w1", "best=key", kT0 + 3).ok());
  EXPECT_EQ(StateOf(*store, job), JobState::kRunning);  // texel still to do
  // The kind filter: a worker that only runs sweeps gets nothing.
  auto sweeps_only = store->LeaseTask("w3", kT0 + 4, kLeaseMs, {"sweep"});
  ASSERT_TRUE(sweeps_only.ok());
  EXPECT_FALSE(sweeps_only->has_value());
  auto texels = store->LeaseTask("w3", kT0 + 4, kLeaseMs, {"sweep", "texel"});
  ASSERT_TRUE(texels.ok());
  ASSERT_TRUE(texels->has_value());
  EXPECT_EQ((*texels)->id, texel);

  // A dependency must belong to the same job.
  auto foreign = store->AddTask(NewTask{job, "texel", "k", other, 0}, kT0);
  EXPECT_EQ(foreign.status().code(), absl::StatusCode::kInvalidArgument) << foreign.status();
}

TEST(JobStoreTest, PermanentFailureFailsTheTaskAndItsJobAtOnce) {
  TestDir dir;
  auto store = OpenOrDie(dir.db(), JobStoreOptions{/*default_max_attempts=*/3});
  const std::string job = CreateJobOrDie(*store);
  const std::string task = AddTaskOrDie(*store, job, "gather", "");
  Task leased = LeaseOrDie(*store, "w1", kT0 + 1);
  ASSERT_EQ(leased.id, task);
  ASSERT_TRUE(store->FailTask(task, "w1", "samples: too large", kT0 + 2, /*permanent=*/true).ok());
  auto state = store->GetTask(task);
  ASSERT_TRUE(state.ok());
  EXPECT_EQ(state->state, TaskState::kFailed);
  EXPECT_EQ(state->attempts, 1);
  auto failed = store->GetJob(job);
  ASSERT_TRUE(failed.ok());
  EXPECT_EQ(failed->state, JobState::kFailed);
  EXPECT_NE(failed->error.find("samples: too large"), std::string::npos) << failed->error;
  EXPECT_EQ(failed->error.find("attempts"), std::string::npos) << failed->error;
}

// Issue #19: a worker's own failure (full cache disk, out of memory) goes
// back to the queue without using an attempt, up to 2 * max_attempts times.
TEST(JobStoreTest, WorkerFaultsRequeueWithoutUsingAttemptsUpToABound) {
  TestDir dir;
  auto store = OpenOrDie(dir.db(), JobStoreOptions{/*default_max_attempts=*/3});
  const std::string job = CreateJobOrDie(*store);
  const std::string task = AddTaskOrDie(*store, job, "gather", "");
  int64_t now = kT0;
  for (int fault = 1; fault <= 6; ++fault) {
    Task leased = LeaseOrDie(*store, "bad", ++now);
    ASSERT_EQ(leased.id, task);
    EXPECT_EQ(leased.attempts, 1) << "fault " << fault;  // every earlier lease was given back
    ASSERT_TRUE(store
                    ->FailTask(task, "bad", "disk full (on worker bad)", ++now, /*permanent=*/false,
                               /*worker_fault=*/true)
                    .ok());
    auto state = store->GetTask(task);
    ASSERT_TRUE(state.ok());
    EXPECT_EQ(state->worker_faults, fault);
    EXPECT_EQ(state->error, "disk full (on worker bad)");
    EXPECT_EQ(state->state, fault < 6 ? TaskState::kQueued : TaskState::kFailed) << "fault " << fault;
    if (fault < 6) {
      EXPECT_EQ(state->attempts, 0);
    }
    auto pending = store->GetJob(job);
    ASSERT_TRUE(pending.ok());
    EXPECT_EQ(pending->state == JobState::kFailed, fault == 6) << "fault " << fault;
  }
  auto failed = store->GetJob(job);
  ASSERT_TRUE(failed.ok());
  EXPECT_NE(failed->error.find("failed 6 times on workers whose own environment failed"), std::string::npos)
      << failed->error;
  EXPECT_NE(failed->error.find("disk full (on worker bad)"), std::string::npos) << failed->error;
}

// A permanent failure stays permanent even when flagged as the worker's.
TEST(JobStoreTest, PermanentWinsOverWorkerFault) {
  TestDir dir;
  auto store = OpenOrDie(dir.db(), JobStoreOptions{/*default_max_attempts=*/3});
  const std::string job = CreateJobOrDie(*store);
  const std::string task = AddTaskOrDie(*store, job, "gather", "");
  LeaseOrDie(*store, "w1", kT0 + 1);
  ASSERT_TRUE(store->FailTask(task, "w1", "bad input", kT0 + 2, /*permanent=*/true, /*worker_fault=*/true).ok());
  auto failed = store->GetJob(job);
  ASSERT_TRUE(failed.ok());
  EXPECT_EQ(failed->state, JobState::kFailed);
}

TEST(JobStoreTest, FailRequeuesUntilMaxAttemptsThenTheJobFails) {
  TestDir dir;
  auto store = OpenOrDie(dir.db(), JobStoreOptions{/*default_max_attempts=*/3});
  const std::string job = CreateJobOrDie(*store);
  const std::string task = AddTaskOrDie(*store, job, "sweep", "key");
  const std::string sibling = AddTaskOrDie(*store, job, "sweep", "fill", std::nullopt, kT0 + 1);
  int64_t now = kT0;
  for (int attempt = 1; attempt <= 3; ++attempt) {
    Task leased = LeaseOrDie(*store, "w" + std::to_string(attempt), ++now);
    ASSERT_EQ(leased.id, task) << "attempt " << attempt;  // older than its sibling
    EXPECT_EQ(leased.attempts, attempt);
    EXPECT_EQ(store->FailTask(task, "someone else", "x", ++now).code(), absl::StatusCode::kFailedPrecondition);
    ASSERT_TRUE(store->FailTask(task, leased.lease_owner, "GL_OUT_OF_MEMORY", ++now).ok());
    auto state = store->GetTask(task);
    ASSERT_TRUE(state.ok());
    EXPECT_EQ(state->state, attempt < 3 ? TaskState::kQueued : TaskState::kFailed);
  }
  auto failed = store->GetJob(job);
  ASSERT_TRUE(failed.ok());
  EXPECT_EQ(failed->state, JobState::kFailed);
  EXPECT_NE(failed->error.find("GL_OUT_OF_MEMORY"), std::string::npos) << failed->error;
  EXPECT_NE(failed->error.find("3 attempts"), std::string::npos) << failed->error;
  auto rest = store->GetTask(sibling);
  ASSERT_TRUE(rest.ok());
  EXPECT_EQ(rest->state, TaskState::kCancelled);
  auto nothing = store->LeaseTask("w9", ++now, kLeaseMs);
  ASSERT_TRUE(nothing.ok());
  EXPECT_FALSE(nothing->has_value());
  EXPECT_EQ(store->AddTask(NewTask{job, "sweep", "late", std::nullopt, 0}, now).status().code(),
            absl::StatusCode::kFailedPrecondition);
}

TEST(JobStoreTest, LeaseExpiringOnTheLastAttemptFailsTheJob) {
  TestDir dir;
  auto store = OpenOrDie(dir.db());
  const std::string job = CreateJobOrDie(*store);
  ASSERT_TRUE(store->AddTask(NewTask{job, "sweep", "crashy", std::nullopt, 1}, kT0).ok());
  LeaseOrDie(*store, "w1", kT0);
  auto nothing = store->LeaseTask("w2", kT0 + kLeaseMs, kLeaseMs);
  ASSERT_TRUE(nothing.ok()) << nothing.status();
  EXPECT_FALSE(nothing->has_value());
  auto failed = store->GetJob(job);
  ASSERT_TRUE(failed.ok());
  EXPECT_EQ(failed->state, JobState::kFailed);
  EXPECT_NE(failed->error.find("expired"), std::string::npos) << failed->error;
}

TEST(JobStoreTest, CancelJob) {
  TestDir dir;
  auto store = OpenOrDie(dir.db());
  const std::string job = CreateJobOrDie(*store);
  const std::string leased = AddTaskOrDie(*store, job, "sweep", "a");
  const std::string queued = AddTaskOrDie(*store, job, "sweep", "b", std::nullopt, kT0 + 1);
  LeaseOrDie(*store, "w1", kT0 + 2);
  ASSERT_TRUE(store->CancelJob(job, kT0 + 3).ok());
  EXPECT_TRUE(store->CancelJob(job, kT0 + 4).ok());  // idempotent
  EXPECT_EQ(StateOf(*store, job), JobState::kCancelled);
  auto tasks = store->TasksOfJob(job);
  ASSERT_TRUE(tasks.ok());
  ASSERT_EQ(tasks->size(), 2u);
  for (const Task& task : *tasks) EXPECT_EQ(task.state, TaskState::kCancelled) << task.key;
  // The worker learns it when it reports back.
  EXPECT_EQ(store->RenewLease(leased, "w1", kT0 + 5, kLeaseMs).code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(store->CompleteTask(leased, "w1", "r", kT0 + 5).code(), absl::StatusCode::kFailedPrecondition);
  auto nothing = store->LeaseTask("w2", kT0 + kLeaseMs * 10, kLeaseMs);
  ASSERT_TRUE(nothing.ok());
  EXPECT_FALSE(nothing->has_value());

  // A finished job cannot be cancelled.
  const std::string done_job = CreateJobOrDie(*store);
  const std::string only = AddTaskOrDie(*store, done_job, "sweep", "a", std::nullopt, kT0 + 6);
  ASSERT_TRUE(store->SealJob(done_job, kT0 + 6).ok());
  LeaseOrDie(*store, "w1", kT0 + 7);
  ASSERT_TRUE(store->CompleteTask(only, "w1", "", kT0 + 8).ok());
  EXPECT_EQ(store->CancelJob(done_job, kT0 + 9).code(), absl::StatusCode::kFailedPrecondition);
  (void)queued;
}

TEST(JobStoreTest, ConcurrentLeasesFromTwoStoresNeverShareATask) {
  constexpr int kTasks = 200;
  TestDir dir;
  std::vector<std::string> ids;
  {
    auto setup = OpenOrDie(dir.db());
    const std::string job = CreateJobOrDie(*setup);
    for (int i = 0; i < kTasks; ++i) ids.push_back(AddTaskOrDie(*setup, job, "sweep", std::to_string(i)));
  }
  auto a = OpenOrDie(dir.db());
  auto b = OpenOrDie(dir.db());
  std::mutex mu;
  std::map<std::string, int> lease_count;
  std::map<std::string, int> per_worker;  // for the record: how the work was shared
  std::atomic<bool> failed{false};
  auto work = [&](JobStore& store, const std::string& worker) {
    // Leases far in the future of each other never expire during the run.
    while (true) {
      auto task = store.LeaseTask(worker, kT0, int64_t{1} << 40);
      if (!task.ok()) {
        ADD_FAILURE() << task.status();
        failed = true;
        return;
      }
      if (!task->has_value()) return;
      {
        std::lock_guard<std::mutex> lock(mu);
        ++lease_count[(*task)->id];
        ++per_worker[worker];
      }
      // "Work" outside the store: without it one connection re-takes the
      // write lock before the other's busy handler wakes up, and the test
      // would not interleave the two at all.
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      absl::Status done = store.CompleteTask((*task)->id, worker, worker, kT0 + 1);
      if (!done.ok()) {
        ADD_FAILURE() << done;
        failed = true;
        return;
      }
    }
  };
  std::thread t1(work, std::ref(*a), "w1");
  std::thread t2(work, std::ref(*b), "w2");
  t1.join();
  t2.join();
  ASSERT_FALSE(failed);
  ASSERT_EQ(lease_count.size(), static_cast<size_t>(kTasks));
  for (const std::string& id : ids) EXPECT_EQ(lease_count[id], 1) << id;
  RecordProperty("leased_by_w1", per_worker["w1"]);
  RecordProperty("leased_by_w2", per_worker["w2"]);
  EXPECT_GT(per_worker["w1"], 0);
  EXPECT_GT(per_worker["w2"], 0);
  a.reset();
  b.reset();
  ExpectIntegrityOk(dir.db());
}

// --- Task graphs (schema version 2) ------------------------------------------

std::optional<Task> TryLease(JobStore& store, const std::string& worker, int64_t now_ms) {
  auto task = store.LeaseTask(worker, now_ms, kLeaseMs);
  EXPECT_TRUE(task.ok()) << task.status();
  return task.ok() ? *task : std::nullopt;
}

TEST(JobStoreGraphTest, SweepFansOutChooseFansInThenTexel) {
  constexpr int kSweeps = 8;
  TestDir dir;
  std::string job;
  std::vector<std::string> sweeps;
  std::string choose;
  {
    auto setup = OpenOrDie(dir.db());
    job = CreateJobOrDie(*setup);
    for (int i = 0; i < kSweeps; ++i) {
      sweeps.push_back(AddTaskOrDie(*setup, job, "sweep", "config" + std::to_string(i)));
    }
    auto added = setup->AddTask(NewTask{job, "choose", "best", TaskIds(sweeps), 0}, kT0 + 1);
    ASSERT_TRUE(added.ok()) << added.status();
    choose = *added;
    auto got = setup->GetTask(choose);
    ASSERT_TRUE(got.ok());
    EXPECT_EQ(got->depends_on, sweeps);  // in the order given
    // The whole graph is known except what "choose" will add: seal.
    ASSERT_TRUE(setup->SealJob(job, kT0 + 1).ok());
    ASSERT_TRUE(setup->SealJob(job, kT0 + 1).ok());  // idempotent
    EXPECT_EQ(setup->AddTask(NewTask{job, "sweep", "late", std::nullopt, 0}, kT0 + 2).status().code(),
              absl::StatusCode::kFailedPrecondition);
  }

  // Two workers (two stores on the file) share the sweep; "choose" is never
  // handed out while a sweep row is unfinished.
  auto a = OpenOrDie(dir.db());
  auto b = OpenOrDie(dir.db());
  std::mutex mu;
  std::map<std::string, int> leased;  // sweep task id -> leases
  std::string chosen_by;              // the worker that leased "choose"
  std::atomic<bool> failed{false};
  auto work = [&](JobStore& store, const std::string& worker) {
    while (true) {
      auto task = store.LeaseTask(worker, kT0 + 10, kLeaseMs, {"sweep", "choose"});
      if (!task.ok()) {
        ADD_FAILURE() << task.status();
        failed = true;
        return;
      }
      if (!task->has_value()) return;
      if ((*task)->kind == "choose") {
        // Handed out only once every sweep row is done.
        auto tasks = store.TasksOfJob(job);
        EXPECT_TRUE(tasks.ok());
        int done = 0;
        for (const Task& t : tasks.ok() ? *tasks : std::vector<Task>{}) {
          done += t.kind == "sweep" && t.state == TaskState::kDone;
        }
        EXPECT_EQ(done, kSweeps) << "choose leased early";
        std::lock_guard<std::mutex> lock(mu);
        chosen_by = worker;
        return;
      }
      {
        std::lock_guard<std::mutex> lock(mu);
        ++leased[(*task)->id];
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
      // This row is not done, so "choose" must not go out.
      auto early = store.LeaseTask(worker + "-probe", kT0 + 10, kLeaseMs, {"choose"});
      EXPECT_TRUE(early.ok() && !early->has_value()) << "choose leased before every sweep row was done";
      absl::Status done = store.CompleteTask((*task)->id, worker, "error=" + (*task)->key, kT0 + 11);
      if (!done.ok()) {
        ADD_FAILURE() << done;
        failed = true;
        return;
      }
    }
  };
  std::thread t1(work, std::ref(*a), "w1");
  std::thread t2(work, std::ref(*b), "w2");
  t1.join();
  t2.join();
  ASSERT_FALSE(failed);
  ASSERT_EQ(leased.size(), static_cast<size_t>(kSweeps));
  for (const std::string& id : sweeps) EXPECT_EQ(leased[id], 1) << id;
  RecordProperty("choose_leased_by", chosen_by);
  ASSERT_FALSE(chosen_by.empty()) << "nobody leased choose after the sweep";
  EXPECT_EQ(StateOf(*a, job), JobState::kRunning);

  // "choose" went out once all rows were done; its completion adds the
  // per-texel tasks (they need the best configuration, known only now).
  auto follow_ups = a->CompleteTask(
      choose, chosen_by, "best=config3", kT0 + 21,
      {NewTask{"", "texel", "config3 tile0", TaskIds(choose), 0},
       NewTask{"", "texel", "config3 tile1", TaskIds{choose}, 0},
       NewTask{job, "assemble", "atlas", TaskIds{FollowUpRef(0), FollowUpRef(1)}, 0}});
  ASSERT_TRUE(follow_ups.ok()) << follow_ups.status();
  ASSERT_EQ(follow_ups->size(), 3u);
  // A retried completion adds nothing again and names the same tasks.
  auto retried = a->CompleteTask(choose, chosen_by, "best=config3", kT0 + 22, {NewTask{"", "texel", "dup", {}, 0}});
  ASSERT_TRUE(retried.ok()) << retried.status();
  EXPECT_EQ(*retried, *follow_ups);
  EXPECT_EQ(StateOf(*a, job), JobState::kRunning);  // sealed, but the follow-ups are not done

  auto assemble = a->GetTask((*follow_ups)[2]);
  ASSERT_TRUE(assemble.ok());
  EXPECT_EQ(assemble->depends_on, std::vector<std::string>({(*follow_ups)[0], (*follow_ups)[1]}));
  EXPECT_EQ(assemble->added_by, std::optional<std::string>(choose));

  Task tile0 = LeaseOrDie(*b, "w2", kT0 + 30);
  Task tile1 = LeaseOrDie(*a, "w1", kT0 + 30);
  EXPECT_EQ(tile0.id, (*follow_ups)[0]);
  EXPECT_EQ(tile1.id, (*follow_ups)[1]);
  EXPECT_FALSE(TryLease(*a, "w3", kT0 + 30).has_value());  // assemble waits for both tiles
  ASSERT_TRUE(b->CompleteTask(tile0.id, "w2", "t0", kT0 + 31).ok());
  EXPECT_FALSE(TryLease(*a, "w3", kT0 + 31).has_value());
  ASSERT_TRUE(a->CompleteTask(tile1.id, "w1", "t1", kT0 + 32).ok());
  Task last = LeaseOrDie(*a, "w3", kT0 + 33);
  EXPECT_EQ(last.id, (*follow_ups)[2]);
  EXPECT_EQ(StateOf(*a, job), JobState::kRunning);
  ASSERT_TRUE(a->CompleteTask(last.id, "w3", "atlas", kT0 + 34).ok());
  EXPECT_EQ(StateOf(*a, job), JobState::kSucceeded);
  a.reset();
  b.reset();
  ExpectIntegrityOk(dir.db());
}

TEST(JobStoreGraphTest, SealingAJobWhoseTasksAreDoneSucceedsIt) {
  TestDir dir;
  auto store = OpenOrDie(dir.db());
  const std::string job = CreateJobOrDie(*store);
  EXPECT_EQ(store->SealJob(job, kT0).code(), absl::StatusCode::kFailedPrecondition);  // no tasks
  EXPECT_EQ(store->SealJob("nope", kT0).code(), absl::StatusCode::kNotFound);
  const std::string first = AddTaskOrDie(*store, job, "sweep", "a");
  const std::string second = AddTaskOrDie(*store, job, "sweep", "b", std::nullopt, kT0 + 1);
  for (int i = 0; i < 2; ++i) {
    Task task = LeaseOrDie(*store, "w1", kT0 + 2);
    ASSERT_TRUE(store->CompleteTask(task.id, "w1", "r", kT0 + 3).ok());
  }
  EXPECT_EQ(StateOf(*store, job), JobState::kRunning);  // the server may still add tasks
  // The server adds the follow-up itself, then seals.
  const std::string third = AddTaskOrDie(*store, job, "choose", "best", std::optional<std::string>(first), kT0 + 4);
  ASSERT_TRUE(store->SealJob(job, kT0 + 5).ok());
  EXPECT_EQ(StateOf(*store, job), JobState::kRunning);
  EXPECT_EQ(LeaseOrDie(*store, "w1", kT0 + 6).id, third);
  ASSERT_TRUE(store->CompleteTask(third, "w1", "r", kT0 + 7).ok());
  EXPECT_EQ(StateOf(*store, job), JobState::kSucceeded);

  // All done first, sealed afterwards: succeeded by SealJob.
  const std::string late = CreateJobOrDie(*store);
  const std::string only = AddTaskOrDie(*store, late, "sweep", "a", std::nullopt, kT0 + 8);
  LeaseOrDie(*store, "w1", kT0 + 9);
  ASSERT_TRUE(store->CompleteTask(only, "w1", "r", kT0 + 10).ok());
  EXPECT_EQ(StateOf(*store, late), JobState::kRunning);
  ASSERT_TRUE(store->SealJob(late, kT0 + 11).ok());
  EXPECT_EQ(StateOf(*store, late), JobState::kSucceeded);
  auto sealed = store->GetJob(late);
  ASSERT_TRUE(sealed.ok());
  EXPECT_TRUE(sealed->sealed);
  (void)second;
}

TEST(JobStoreGraphTest, BadFollowUpsAddNothingAndKeepTheLease) {
  TestDir dir;
  auto store = OpenOrDie(dir.db());
  const std::string job = CreateJobOrDie(*store);
  const std::string other_job = CreateJobOrDie(*store);
  const std::string foreign = AddTaskOrDie(*store, other_job, "sweep", "x");
  const std::string task = AddTaskOrDie(*store, job, "choose", "best", std::nullopt, kT0 + 1);
  ASSERT_TRUE(store->SealJob(job, kT0 + 1).ok());
  EXPECT_EQ(LeaseOrDie(*store, "w1", kT0 + 2).id, foreign);
  EXPECT_EQ(LeaseOrDie(*store, "w1", kT0 + 2).id, task);
  for (const NewTask& bad : {NewTask{other_job, "texel", "t", {}, 0}, NewTask{"", "texel", "t", foreign, 0},
                             NewTask{"", "texel", "t", FollowUpRef(0), 0}, NewTask{"", "texel", "t", "unknown", 0}}) {
    auto refused = store->CompleteTask(task, "w1", "r", kT0 + 3, {bad});
    EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument) << refused.status();
  }
  auto still = store->GetTask(task);
  ASSERT_TRUE(still.ok());
  EXPECT_EQ(still->state, TaskState::kLeased);
  auto tasks = store->TasksOfJob(job);
  ASSERT_TRUE(tasks.ok());
  EXPECT_EQ(tasks->size(), 1u);
  auto added = store->CompleteTask(task, "w1", "r", kT0 + 4, {NewTask{"", "texel", "t", TaskIds{task, task}, 0}});
  ASSERT_TRUE(added.ok()) << added.status();
  auto texel = store->GetTask(added->at(0));
  ASSERT_TRUE(texel.ok());
  EXPECT_EQ(texel->depends_on, std::vector<std::string>{task});  // duplicates ignored
}

TEST(JobStoreGraphTest, AFailedDependencyFailsItsDependents) {
  TestDir dir;
  auto store = OpenOrDie(dir.db(), JobStoreOptions{/*default_max_attempts=*/1});
  const std::string job = CreateJobOrDie(*store);
  const std::string bad = AddTaskOrDie(*store, job, "sweep", "a");
  const std::string good = AddTaskOrDie(*store, job, "sweep", "b", std::nullopt, kT0 + 1);
  auto choose = store->AddTask(NewTask{job, "choose", "best", TaskIds{bad, good}, 0}, kT0 + 2);
  ASSERT_TRUE(choose.ok());
  const std::string texel = AddTaskOrDie(*store, job, "texel", "t", *choose, kT0 + 3);
  const std::string unrelated = AddTaskOrDie(*store, job, "sweep", "c", std::nullopt, kT0 + 4);
  ASSERT_TRUE(store->SealJob(job, kT0 + 4).ok());
  EXPECT_EQ(LeaseOrDie(*store, "w1", kT0 + 5).id, bad);
  ASSERT_TRUE(store->FailTask(bad, "w1", "GL_OUT_OF_MEMORY", kT0 + 6).ok());
  EXPECT_EQ(StateOf(*store, job), JobState::kFailed);
  for (const std::string& id : {*choose, texel}) {
    auto dependent = store->GetTask(id);
    ASSERT_TRUE(dependent.ok());
    EXPECT_EQ(dependent->state, TaskState::kFailed) << dependent->key;
    EXPECT_NE(dependent->error.find(bad), std::string::npos) << dependent->error;
  }
  for (const std::string& id : {good, unrelated}) {
    auto rest = store->GetTask(id);
    ASSERT_TRUE(rest.ok());
    EXPECT_EQ(rest->state, TaskState::kCancelled) << rest->key;
  }
  store.reset();
  ExpectIntegrityOk(dir.db());
}

TEST(JobStoreGraphTest, VersionOneDatabaseUpgradesInPlace) {
  TestDir dir;
  {
    auto db = SqliteDb::Open(dir.db());
    ASSERT_TRUE(db.ok()) << db.status();
    ASSERT_TRUE(ApplyMigrationsUpTo(**db, 1).ok());
    auto version = SchemaVersion(**db);
    ASSERT_TRUE(version.ok());
    ASSERT_EQ(*version, 1);
    // What a version 1 server left behind: a running job (sweep done, texel
    // depending on it, queued), a finished one, and one without tasks yet.
    ASSERT_TRUE((*db)->Exec(R"sql(
INSERT INTO jobs (id, client, state, scene_hash, request, created_ms, updated_ms) VALUES
  ('j1', 'alice', 'running', 'h', x'00', 1, 1),
  ('j2', 'alice', 'succeeded', 'h', x'00', 1, 1),
  ('j3', 'bob', 'queued', 'h', x'00', 1, 1);
INSERT INTO tasks (id, job_id, kind, key, depends_on, state, attempts, max_attempts, lease_owner, result,
                   created_ms, updated_ms) VALUES
  ('s1', 'j1', 'sweep', 'all', NULL, 'done', 1, 3, 'w1', x'72', 1, 1),
  ('x1', 'j1', 'texel', 'best', 's1', 'queued', 0, 3, NULL, NULL, 2, 2),
  ('s2', 'j2', 'sweep', 'all', NULL, 'done', 1, 3, 'w1', x'72', 1, 1),
  ('x2', 'j2', 'texel', 'best', 's2', 'done', 1, 3, 'w1', x'72', 2, 2);
)sql").ok());
  }
  auto store = OpenOrDie(dir.db());
  {
    auto db = SqliteDb::Open(dir.db());
    ASSERT_TRUE(db.ok());
    auto version = SchemaVersion(**db);
    ASSERT_TRUE(version.ok());
    EXPECT_EQ(*version, kSchemaVersion);
  }
  auto texel = store->GetTask("x1");
  ASSERT_TRUE(texel.ok()) << texel.status();
  EXPECT_EQ(texel->depends_on, std::vector<std::string>{"s1"});
  EXPECT_FALSE(texel->added_by.has_value());
  auto j1 = store->GetJob("j1");
  auto j2 = store->GetJob("j2");
  auto j3 = store->GetJob("j3");
  ASSERT_TRUE(j1.ok() && j2.ok() && j3.ok());
  EXPECT_TRUE(j1->sealed);
  EXPECT_TRUE(j2->sealed);
  EXPECT_FALSE(j3->sealed);  // its server was about to add tasks
  EXPECT_EQ(j2->state, JobState::kSucceeded);
  // The version 1 job carries on with its version 1 meaning.
  Task leased = LeaseOrDie(*store, "w2", kT0);
  EXPECT_EQ(leased.id, "x1");
  ASSERT_TRUE(store->CompleteTask("x1", "w2", "done", kT0 + 1).ok());
  EXPECT_EQ(StateOf(*store, "j1"), JobState::kSucceeded);
  EXPECT_TRUE(AddTaskOrDie(*store, "j3", "sweep", "a", std::nullopt, kT0 + 2).size() == 32u);
  store.reset();
  ExpectIntegrityOk(dir.db());
  auto reopened = OpenOrDie(dir.db());  // nothing re-applied
  ASSERT_NE(reopened, nullptr);
}

TEST(JobStoreGraphTest, RedoDependencyQueuesTheLostGatherAndItsSweepBehindIt) {
  TestDir dir;
  auto store = OpenOrDie(dir.db());
  const std::string job = CreateJobOrDie(*store);
  const std::string gather = AddTaskOrDie(*store, job, "gather", "*");
  const std::string sweep_a = AddTaskOrDie(*store, job, "sweep", "A", gather);
  const std::string sweep_b = AddTaskOrDie(*store, job, "sweep", "B", gather);
  ASSERT_TRUE(store->SealJob(job, kT0).ok());

  EXPECT_EQ(LeaseOrDie(*store, "w1", kT0).id, gather);
  ASSERT_TRUE(store->CompleteTask(gather, "w1", "gathered", kT0 + 1).ok());
  EXPECT_EQ(LeaseOrDie(*store, "w1", kT0 + 2).id, sweep_a);
  EXPECT_EQ(LeaseOrDie(*store, "w2", kT0 + 2).id, sweep_b);

  // Only the lease owner, and only for a real dependency.
  EXPECT_EQ(store->RedoDependency(sweep_a, "w2", gather, "lost", kT0 + 3).code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(store->RedoDependency(sweep_a, "w1", sweep_b, "lost", kT0 + 3).code(),
            absl::StatusCode::kInvalidArgument);

  // The Samples are gone: the gather runs again, both sweeps wait for it and
  // their leases do not count as attempts.
  ASSERT_TRUE(store->RedoDependency(sweep_a, "w1", gather, "samples lost", kT0 + 3).ok());
  ASSERT_TRUE(store->RedoDependency(sweep_b, "w2", gather, "samples lost", kT0 + 3).ok());
  auto redone = store->GetTask(gather);
  ASSERT_TRUE(redone.ok());
  EXPECT_EQ(redone->state, TaskState::kQueued);
  EXPECT_FALSE(redone->result.has_value());
  EXPECT_EQ(redone->error, "samples lost");
  EXPECT_EQ(StateOf(*store, job), JobState::kRunning);
  Task again = LeaseOrDie(*store, "w2", kT0 + 4);
  EXPECT_EQ(again.id, gather);
  EXPECT_EQ(again.attempts, 2);
  auto nothing = store->LeaseTask("w1", kT0 + 4, kLeaseMs);
  ASSERT_TRUE(nothing.ok());
  EXPECT_FALSE(nothing->has_value()) << "a sweep was leased before its gather was done again";
  ASSERT_TRUE(store->CompleteTask(gather, "w2", "gathered again", kT0 + 5).ok());
  for (const std::string& sweep : {sweep_a, sweep_b}) {
    Task leased = LeaseOrDie(*store, "w1", kT0 + 6);
    EXPECT_EQ(leased.attempts, 1) << leased.key;
    ASSERT_TRUE(store->CompleteTask(leased.id, "w1", "row", kT0 + 7).ok());
    (void)sweep;
  }
  EXPECT_EQ(StateOf(*store, job), JobState::kSucceeded);
  ExpectIntegrityOk(dir.db());
}

TEST(JobStoreGraphTest, RedoDependencyFailsTheJobOnceTheGatherUsedItsAttempts) {
  TestDir dir;
  JobStoreOptions options;
  options.default_max_attempts = 2;
  auto store = OpenOrDie(dir.db(), options);
  const std::string job = CreateJobOrDie(*store);
  const std::string gather = AddTaskOrDie(*store, job, "gather", "*");
  const std::string sweep = AddTaskOrDie(*store, job, "sweep", "A", gather);
  ASSERT_TRUE(store->SealJob(job, kT0).ok());
  for (int round = 0; round < 2; ++round) {
    EXPECT_EQ(LeaseOrDie(*store, "w1", kT0 + 10 * round).id, gather);
    ASSERT_TRUE(store->CompleteTask(gather, "w1", "gathered", kT0 + 10 * round + 1).ok());
    EXPECT_EQ(LeaseOrDie(*store, "w1", kT0 + 10 * round + 2).id, sweep);
    ASSERT_TRUE(store->RedoDependency(sweep, "w1", gather, "evicted", kT0 + 10 * round + 3).ok());
  }
  // The second redo found the gather at its limit: the job failed with why.
  auto failed = store->GetJob(job);
  ASSERT_TRUE(failed.ok());
  EXPECT_EQ(failed->state, JobState::kFailed);
  EXPECT_NE(failed->error.find("evicted"), std::string::npos) << failed->error;
  EXPECT_NE(failed->error.find("maximum number of times"), std::string::npos) << failed->error;
}

TEST(JobStoreTest, LeaseStampsStartedMsAndSamplesFromCacheIsRecorded) {
  TestDir dir;
  auto store = OpenOrDie(dir.db());
  const std::string job = CreateJobOrDie(*store);
  const std::string task = AddTaskOrDie(*store, job, "gather", "");
  auto fresh = store->GetTask(task);
  ASSERT_TRUE(fresh.ok());
  EXPECT_EQ(fresh->started_ms, 0);
  EXPECT_FALSE(fresh->samples_from_cache);

  LeaseOrDie(*store, "w1", kT0 + 100);
  // The lease expires; the second lease restarts the clock.
  LeaseOrDie(*store, "w2", kT0 + 100 + kLeaseMs + 1);
  ASSERT_TRUE(store->SetSamplesFromCache(task, true).ok());
  ASSERT_TRUE(store->CompleteTask(task, "w2", "r", kT0 + 100 + kLeaseMs + 5000).ok());
  auto done = store->GetTask(task);
  ASSERT_TRUE(done.ok());
  EXPECT_EQ(done->started_ms, kT0 + 100 + kLeaseMs + 1);
  EXPECT_EQ(done->updated_ms - done->started_ms, 4999);
  EXPECT_TRUE(done->samples_from_cache);
  ASSERT_TRUE(store->SetSamplesFromCache(task, false).ok());
  EXPECT_FALSE(store->GetTask(task)->samples_from_cache);
  EXPECT_EQ(store->SetSamplesFromCache("nope", true).code(), absl::StatusCode::kNotFound);
}

TEST(JobStoreGraphTest, VersionTwoDatabaseUpgradesInPlace) {
  TestDir dir;
  {
    auto db = SqliteDb::Open(dir.db());
    ASSERT_TRUE(db.ok()) << db.status();
    ASSERT_TRUE(ApplyMigrationsUpTo(**db, 2).ok());
    auto version = SchemaVersion(**db);
    ASSERT_TRUE(version.ok());
    ASSERT_EQ(*version, 2);
    // What a version 2 server left behind: a running job with a done gather
    // and a queued sweep depending on it.
    ASSERT_TRUE((*db)->Exec(R"sql(
INSERT INTO jobs (id, client, state, scene_hash, request, created_ms, updated_ms, sealed) VALUES
  ('j1', 'alice', 'running', 'h', x'00', 1, 1, 1);
INSERT INTO tasks (id, job_id, kind, key, state, attempts, max_attempts, lease_owner, result,
                   created_ms, updated_ms) VALUES
  ('g1', 'j1', 'gather', '', 'done', 1, 3, 'w1', x'72', 1, 5),
  ('s1', 'j1', 'sweep', 'all', 'queued', 0, 3, NULL, NULL, 2, 2);
INSERT INTO task_deps (task_id, depends_on) VALUES ('s1', 'g1');
)sql").ok());
  }
  auto store = OpenOrDie(dir.db());
  {
    auto db = SqliteDb::Open(dir.db());
    ASSERT_TRUE(db.ok());
    auto version = SchemaVersion(**db);
    ASSERT_TRUE(version.ok());
    EXPECT_EQ(*version, kSchemaVersion);
  }
  auto gather = store->GetTask("g1");
  ASSERT_TRUE(gather.ok()) << gather.status();
  EXPECT_EQ(gather->started_ms, 0);  // unknown: leased by a version 2 server
  EXPECT_FALSE(gather->samples_from_cache);
  Task sweep = LeaseOrDie(*store, "w2", kT0);
  EXPECT_EQ(sweep.id, "s1");
  EXPECT_EQ(sweep.started_ms, kT0);
  EXPECT_EQ(sweep.depends_on, std::vector<std::string>{"g1"});
  ASSERT_TRUE(store->CompleteTask("s1", "w2", "row", kT0 + 1).ok());
  EXPECT_EQ(StateOf(*store, "j1"), JobState::kSucceeded);
  store.reset();
  ExpectIntegrityOk(dir.db());
  auto reopened = OpenOrDie(dir.db());  // nothing re-applied
  ASSERT_NE(reopened, nullptr);
}

}  // namespace
}  // namespace mvbrdf::store

namespace mvbrdf::store {
namespace {

// Issue #20: a version 4 file (no workers table, no stage_finished) opens
// and migrates; its tasks have no worker name or report; new workers and
// reports are kept from then on, also across a reopen.
TEST(JobStoreMigrationTest, Version4DatabaseGainsWorkerNamesAndStageReports) {
  TestDir dir;
  {
    auto db = SqliteDb::Open(dir.db());
    ASSERT_TRUE(db.ok());
    ASSERT_TRUE(ApplyMigrationsUpTo(**db, 4).ok());
    ASSERT_TRUE((*db)->Exec(R"sql(
INSERT INTO jobs (id, client, state, scene_hash, request, created_ms, updated_ms, sealed) VALUES
  ('j1', 'alice', 'running', 'h', x'00', 1, 1, 1);
INSERT INTO tasks (id, job_id, kind, key, state, attempts, max_attempts, lease_owner, result,
                   created_ms, updated_ms) VALUES
  ('g1', 'j1', 'gather', '', 'done', 1, 3, 'old-worker', x'72', 1, 5),
  ('s1', 'j1', 'sweep', 'NE', 'queued', 0, 3, NULL, NULL, 2, 2);
INSERT INTO task_deps (task_id, depends_on) VALUES ('s1', 'g1');
)sql").ok());
  }
  auto store = OpenOrDie(dir.db());
  auto gather = store->GetTask("g1");
  ASSERT_TRUE(gather.ok()) << gather.status();
  EXPECT_EQ(gather->worker_name, "");  // registered before names were kept
  EXPECT_FALSE(gather->stage_finished.has_value());

  ASSERT_TRUE(store->RegisterWorker("w2id", "studio-gpu-1", kT0).ok());
  Task sweep = LeaseOrDie(*store, "w2id", kT0);
  EXPECT_EQ(sweep.id, "s1");
  // Only the lease owner reports the stage.
  EXPECT_EQ(store->SetStageFinished("s1", "someone-else", "x").code(), absl::StatusCode::kFailedPrecondition);
  ASSERT_TRUE(store->SetStageFinished("s1", "w2id", "report bytes").ok());
  ASSERT_TRUE(store->CompleteTask("s1", "w2id", "row", kT0 + 1).ok());
  store.reset();
  ExpectIntegrityOk(dir.db());
  auto reopened = OpenOrDie(dir.db());
  auto tasks = reopened->TasksOfJob("j1");
  ASSERT_TRUE(tasks.ok()) << tasks.status();
  ASSERT_EQ(tasks->size(), 2u);
  EXPECT_EQ((*tasks)[1].worker_name, "studio-gpu-1");
  EXPECT_EQ((*tasks)[1].lease_owner, "w2id");
  EXPECT_EQ((*tasks)[1].stage_finished.value_or(""), "report bytes");
  EXPECT_EQ(StateOf(*reopened, "j1"), JobState::kSucceeded);
}

}  // namespace
}  // namespace mvbrdf::store
