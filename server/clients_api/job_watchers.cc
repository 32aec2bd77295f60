#include "server/clients_api/job_watchers.h"

#include <deque>
#include <utility>
#include <vector>

#include "server/clients_api/job_proto.h"

namespace mvbrdf::clients_api {
namespace {

// What a watcher has told its client so far.
struct Seen {
  store::JobState state = store::JobState::kQueued;
  std::set<std::string> done_tasks;
  std::set<std::string> started_tasks;
};

struct Snapshot {
  store::Job job;
  std::vector<store::Task> tasks;
};

absl::StatusOr<Snapshot> TakeSnapshot(store::JobStore& jobs, const std::string& job_id) {
  Snapshot snapshot;
  absl::StatusOr<store::Job> job = jobs.GetJob(job_id);
  if (!job.ok()) return job.status();
  absl::StatusOr<std::vector<store::Task>> tasks = jobs.TasksOfJob(job_id);
  if (!tasks.ok()) return tasks.status();
  snapshot.job = *std::move(job);
  snapshot.tasks = *std::move(tasks);
  return snapshot;
}

// The events that take a client from `seen` to `now` (updating `seen`):
// (initial only) a StageStarted per task leased so far, a StageFinished per
// newly done task, then the state when it changed (and
// the reason after FAILED). `initial`: the state is sent even if unchanged.
std::vector<v1::JobEvent> Diff(Seen& seen, const Snapshot& now, bool initial, int64_t now_ms) {
  std::vector<v1::JobEvent> events;
  const auto event = [&]() -> v1::JobEvent& {
    v1::JobEvent& e = events.emplace_back();
    e.set_job_id(now.job.id);
    e.set_unix_ms(now_ms);
    return e;
  };
  for (const store::Task& task : now.tasks) {
    // A watch that joins late learns which tasks started, and on which
    // worker; later starts arrive from the workers' service via Push.
    if (initial && !task.lease_owner.empty() && seen.started_tasks.insert(task.id).second) {
      v1::StageStarted* started = event().mutable_stage_started();
      started->set_stage(task.kind);
      started->set_task_id(task.id);
      started->set_worker(task.lease_owner);
      started->set_worker_name(task.worker_name);
      started->set_key(task.key);
    }
    if (task.state != store::TaskState::kDone || !seen.done_tasks.insert(task.id).second) continue;
    // One event per finished task: the worker's own report (its run time
    // and metrics) as the store keeps it, else the time of the last lease.
    v1::StageFinished* finished = event().mutable_stage_finished();
    if (!task.stage_finished.has_value() || !finished->ParseFromString(*task.stage_finished)) {
      finished->Clear();
      finished->set_stage(task.kind);
      finished->set_seconds(ToProto(task).seconds());
    }
    finished->set_key(task.key);
    finished->set_task_id(task.id);
    finished->set_worker_name(task.worker_name);
  }
  if (initial || now.job.state != seen.state) {
    event().set_state(ToProto(now.job.state));
    if (now.job.state == store::JobState::kFailed) event().set_failed(now.job.error);
  }
  seen.state = now.job.state;
  return events;
}

}  // namespace

// One WatchJob stream. Events are queued and written one at a time; the
// stream finishes after the last event once `finish_after_queue_` is set, or
// at once when the client cancels.
class JobWatch final : public grpc::ServerWriteReactor<v1::JobEvent> {
 public:
  JobWatch(JobWatchers* owner, std::string job_id) : owner_(owner), job_id_(std::move(job_id)) {}

  const std::string& job_id() const { return job_id_; }
  Seen& seen() { return seen_; }  // the poller's; guarded by owner_->mu_

  // Queues events; `last`: the stream ends after them.
  void Enqueue(std::vector<v1::JobEvent> events, bool last) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (finished_ || finish_after_queue_) return;
      for (v1::JobEvent& e : events) queue_.push_back(std::move(e));
      finish_after_queue_ = last;
      if (writing_) return;
    }
    WriteNext();
  }

  void FinishNow(const grpc::Status& status) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (finished_) return;
      finished_ = true;
    }
    Finish(status);
  }

  void OnWriteDone(bool ok) override {
    bool cancelled = false;
    {
      std::lock_guard<std::mutex> lock(mu_);
      writing_ = false;
      cancelled = cancelled_;
    }
    // A write in flight when the client cancelled may still complete (ok):
    // OnCancel left the finishing to this call, so it finishes either way
    // (the stream never ended and the server's shutdown waited for it).
    if (!ok || cancelled) {
      FinishNow(grpc::Status(grpc::StatusCode::CANCELLED, "the watch ended"));
      return;
    }
    WriteNext();
  }

  void OnCancel() override {
    bool finish = false;
    {
      std::lock_guard<std::mutex> lock(mu_);
      cancelled_ = true;
      // With a write in flight, OnWriteDone finishes (ok or not).
      finish = !writing_ && !finished_;
      if (finish) finished_ = true;
    }
    if (finish) Finish(grpc::Status::CANCELLED);
  }

  void OnDone() override {
    owner_->Remove(this);
    delete this;
  }

 private:
  // Starts the next write, or finishes when the queue is drained after the
  // last event.
  void WriteNext() {
    bool finish = false, cancelled = false;
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (writing_ || finished_) return;
      if (cancelled_) {
        finished_ = true;
        cancelled = true;
      } else if (queue_.empty()) {
        if (!finish_after_queue_) return;
        finished_ = finish = true;
      } else {
        current_ = std::move(queue_.front());
        queue_.pop_front();
        writing_ = true;
      }
    }
    if (cancelled) {
      Finish(grpc::Status::CANCELLED);
    } else if (finish) {
      Finish(grpc::Status::OK);
    } else {
      StartWrite(&current_);
    }
  }

  JobWatchers* const owner_;
  const std::string job_id_;
  Seen seen_;

  std::mutex mu_;
  std::deque<v1::JobEvent> queue_;   // guarded by mu_
  v1::JobEvent current_;             // being written (alive until OnWriteDone)
  bool writing_ = false;             // guarded by mu_
  bool finish_after_queue_ = false;  // guarded by mu_
  bool finished_ = false;            // Finish was called; guarded by mu_
  bool cancelled_ = false;           // OnCancel ran; guarded by mu_
};

JobWatchers::JobWatchers(store::JobStore& jobs, std::function<int64_t()> clock,
                         std::chrono::milliseconds poll_interval)
    : jobs_(jobs), clock_(std::move(clock)), poll_interval_(poll_interval) {
  poller_ = std::thread([this] { PollLoop(); });
}

JobWatchers::~JobWatchers() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  wake_.notify_all();
  poller_.join();
}

grpc::ServerWriteReactor<v1::JobEvent>* JobWatchers::Watch(const std::string& job_id) {
  auto* watch = new JobWatch(this, job_id);
  {
    std::lock_guard<std::mutex> lock(mu_);
    ++active_;
  }
  absl::StatusOr<Snapshot> snapshot = TakeSnapshot(jobs_, job_id);
  if (!snapshot.ok()) {
    watch->FinishNow(ToGrpc(snapshot.status()));
    return watch;
  }
  // Registered and replayed under mu_, so that the poller's first events
  // come after the replay and OnDone cannot run before registration.
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<v1::JobEvent> events = Diff(watch->seen(), *snapshot, /*initial=*/true, clock_());
  const bool last = store::IsFinal(snapshot->job.state);
  if (!last) watches_[job_id].insert(watch);
  watch->Enqueue(std::move(events), last);
  return watch;
}

void JobWatchers::Push(const v1::JobEvent& event) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = watches_.find(event.job_id());
  if (it == watches_.end()) return;
  // Finished stages and states come from the store (the poller's Diff):
  // exactly one StageFinished per task, in order before the final state.
  if (event.has_stage_finished() || event.has_state() || event.has_failed()) return;
  for (JobWatch* watch : it->second) {
    // A start the replay already showed (the task was leased between the
    // store write and this push) is not sent twice.
    if (event.has_stage_started() && !watch->seen().started_tasks.insert(event.stage_started().task_id()).second) {
      continue;
    }
    watch->Enqueue({event}, /*last=*/false);
  }
}

size_t JobWatchers::ActiveWatches() const {
  std::lock_guard<std::mutex> lock(mu_);
  return active_;
}

void JobWatchers::Remove(JobWatch* watch) {
  std::lock_guard<std::mutex> lock(mu_);
  --active_;
  auto it = watches_.find(watch->job_id());
  if (it == watches_.end()) return;
  it->second.erase(watch);
  if (it->second.empty()) watches_.erase(it);
}

void JobWatchers::PollLoop() {
  std::unique_lock<std::mutex> lock(mu_);
  while (!stop_) {
    wake_.wait_for(lock, poll_interval_, [this] { return stop_; });
    if (stop_) break;
    lock.unlock();
    PollOnce();
    lock.lock();
  }
}

void JobWatchers::PollOnce() {
  std::vector<std::string> job_ids;
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (const auto& [job_id, watches] : watches_) job_ids.push_back(job_id);
  }
  for (const std::string& job_id : job_ids) {
    absl::StatusOr<Snapshot> snapshot = TakeSnapshot(jobs_, job_id);
    if (!snapshot.ok()) continue;  // transient (e.g. busy database): next round
    const int64_t now_ms = clock_();
    std::lock_guard<std::mutex> lock(mu_);
    auto it = watches_.find(job_id);
    if (it == watches_.end()) continue;
    const bool last = store::IsFinal(snapshot->job.state);
    for (JobWatch* watch : it->second) {
      std::vector<v1::JobEvent> events = Diff(watch->seen(), *snapshot, /*initial=*/false, now_ms);
      if (!events.empty() || last) watch->Enqueue(std::move(events), last);
    }
    // Finished streams need no more polling; their OnDone finds nothing.
    if (last) watches_.erase(it);
  }
}

}  // namespace mvbrdf::clients_api
