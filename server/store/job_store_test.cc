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

}  // namespace
}  // namespace mvbrdf::store
