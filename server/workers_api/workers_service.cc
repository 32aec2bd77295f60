#include "server/workers_api/workers_service.h"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "server/store/digest.h"

namespace mvbrdf::server {
namespace {

constexpr size_t kMaxWorkerNameChars = 128;
// Tasks whose job request does not parse are failed and skipped; this many at
// most per lease attempt (each failure bumps the task's attempts, so a bad
// job fails for good after max_attempts anyway).
constexpr int kMaxSkippedTasksPerLease = 16;

// absl and gRPC share the canonical status codes and their numbers.
grpc::Status ToGrpc(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()), std::string(status.message()));
}

}  // namespace

absl::Status WorkersServiceOptions::Check() const {
  if (lease_seconds <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("lease_seconds: must be > 0, got ", lease_seconds));
  }
  if (max_wait_seconds < 0) {
    return absl::InvalidArgumentError(absl::StrCat("max_wait_seconds: must be >= 0, got ", max_wait_seconds));
  }
  if (max_artifact_bytes <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("max_artifact_bytes: must be > 0, got ", max_artifact_bytes));
  }
  if (poll_interval_ms <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("poll_interval_ms: must be > 0, got ", poll_interval_ms));
  }
  return absl::OkStatus();
}

// ---------------------------------------------------------------- reactors

// A parked LeaseTask call. Only the poller thread (or Stop()) finishes it,
// exactly once; OnCancel only flags it and wakes the poller.
class WorkersService::LeasePoll final : public grpc::ServerUnaryReactor {
 public:
  LeasePoll(WorkersService* service, v1::LeaseTaskResponse* response) : service_(service), response_(response) {}

  void OnCancel() override {
    cancelled_.store(true);
    {
      std::lock_guard<std::mutex> lock(service_->poll_mu_);
      service_->wake_ = true;
    }
    service_->poll_cv_.notify_one();
  }
  void OnDone() override { delete this; }

  bool cancelled() const { return cancelled_.load(); }
  v1::LeaseTaskResponse* response() { return response_; }

 private:
  WorkersService* const service_;
  v1::LeaseTaskResponse* const response_;
  std::atomic<bool> cancelled_{false};
};

// One ReportTask stream: the updates of one task by its lease owner.
class WorkersService::ReportReactor final : public grpc::ServerReadReactor<v1::TaskUpdate> {
 public:
  ReportReactor(WorkersService* service, v1::TaskUpdateAck* ack) : service_(service), ack_(ack) {
    StartRead(&update_);
  }

  void OnReadDone(bool ok) override {
    absl::StatusOr<Step> step = ok ? Apply(update_) : EndOfStream();
    if (!step.ok()) {
      Finish(ToGrpc(step.status()));
    } else if (*step == Step::kNext) {
      StartRead(&update_);
    } else {
      ack_->set_accepted(*step == Step::kAccepted);
      Finish(grpc::Status::OK);
    }
  }
  // A cancelled stream's pending read completes with ok = false.
  void OnCancel() override {}
  void OnDone() override { delete this; }

 private:
  enum class Step { kNext, kAccepted, kLeaseLost };

  struct PartialArtifact {
    std::string bytes;
    uint64_t total_size = 0;
    std::string sha256;  // expected; empty: not given
  };

  absl::StatusOr<Step> Apply(const v1::TaskUpdate& update);
  absl::StatusOr<Step> EndOfStream() const;
  absl::Status AddChunk(const std::string& name, const v1::ArtifactChunk& chunk);

  WorkersService* const service_;
  v1::TaskUpdateAck* const ack_;
  v1::TaskUpdate update_;
  // Set by the first update; every later one must name the same.
  std::string worker_id_;
  std::string task_id_;
  std::string job_id_;
  std::map<std::string, PartialArtifact> partial_;  // by artifact name
};

absl::StatusOr<WorkersService::ReportReactor::Step> WorkersService::ReportReactor::Apply(
    const v1::TaskUpdate& update) {
  if (task_id_.empty()) {
    if (update.task_id().empty()) return absl::InvalidArgumentError("task_id: required");
    MVBRDF_RETURN_IF_ERROR(service_->CheckWorker(update.worker_id()));
    worker_id_ = update.worker_id();
    task_id_ = update.task_id();
  } else if (update.worker_id() != worker_id_ || update.task_id() != task_id_) {
    return absl::InvalidArgumentError(absl::StrCat("task_id/worker_id: a stream reports one task of one worker; got '",
                                                   update.task_id(), "' of '", update.worker_id(), "' after '",
                                                   task_id_, "' of '", worker_id_, "'"));
  }
  // The lease is the store's: lost when the task is no longer leased to us
  // (taken over after expiry, cancelled, failed).
  absl::StatusOr<store::Task> task = service_->jobs_.GetTask(task_id_);
  if (!task.ok()) return task.status();
  if (task->state != store::TaskState::kLeased || task->lease_owner != worker_id_) return Step::kLeaseLost;
  job_id_ = task->job_id;

  const int64_t now_ms = service_->clock_();
  v1::JobEvent event;
  event.set_job_id(job_id_);
  event.set_unix_ms(now_ms);
  switch (update.update_case()) {
    case v1::TaskUpdate::kProgress:
      *event.mutable_progress() = update.progress();
      service_->Emit(std::move(event));
      return Step::kNext;
    case v1::TaskUpdate::kStageFinished:
      *event.mutable_stage_finished() = update.stage_finished();
      service_->Emit(std::move(event));
      return Step::kNext;
    case v1::TaskUpdate::kArtifact: {
      absl::Status added = AddChunk(update.artifact_name(), update.artifact());
      if (!added.ok()) return added;
      return Step::kNext;
    }
    case v1::TaskUpdate::kResult: {
      if (!partial_.empty()) {
        const auto& [name, partial] = *partial_.begin();
        return absl::InvalidArgumentError(absl::StrCat("result: artifact '", name, "' is incomplete (",
                                                       partial.bytes.size(), " of ", partial.total_size, " bytes)"));
      }
      absl::Status completed = service_->jobs_.CompleteTask(task_id_, worker_id_, update.result(), now_ms);
      if (absl::IsFailedPrecondition(completed)) return Step::kLeaseLost;
      if (!completed.ok()) return completed;
      service_->NotifyWork();  // dependents may be leasable now
      service_->EmitFinalState(job_id_);
      return Step::kAccepted;
    }
    case v1::TaskUpdate::kFailed: {
      const std::string reason = update.failed().empty() ? "the worker gave no reason" : update.failed();
      absl::Status failed = service_->jobs_.FailTask(task_id_, worker_id_, reason, now_ms);
      if (absl::IsFailedPrecondition(failed)) return Step::kLeaseLost;
      if (!failed.ok()) return failed;
      service_->NotifyWork();  // requeued for another attempt
      service_->EmitFinalState(job_id_);
      return Step::kAccepted;
    }
    case v1::TaskUpdate::UPDATE_NOT_SET:
      break;
  }
  return absl::InvalidArgumentError(
      "update: one of progress, stage_finished, artifact, result or failed is required");
}

absl::StatusOr<WorkersService::ReportReactor::Step> WorkersService::ReportReactor::EndOfStream() const {
  if (task_id_.empty()) return absl::InvalidArgumentError("ReportTask: the stream had no updates");
  if (!partial_.empty()) {
    const auto& [name, partial] = *partial_.begin();
    return absl::InvalidArgumentError(absl::StrCat("artifact '", name, "': the stream ended after ",
                                                   partial.bytes.size(), " of ", partial.total_size, " bytes"));
  }
  return Step::kAccepted;
}

absl::Status WorkersService::ReportReactor::AddChunk(const std::string& name, const v1::ArtifactChunk& chunk) {
  if (name.empty()) return absl::InvalidArgumentError("artifact_name: required with an artifact chunk");
  auto it = partial_.find(name);
  if (it == partial_.end()) {
    if (chunk.offset() != 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("artifact.offset: the first chunk of '", name, "' must start at 0, got ", chunk.offset()));
    }
    if (chunk.total_size() > static_cast<uint64_t>(service_->options_.max_artifact_bytes)) {
      return absl::ResourceExhaustedError(absl::StrCat("artifact.total_size: ", chunk.total_size(), " bytes of '",
                                                       name, "' exceed the limit of ",
                                                       service_->options_.max_artifact_bytes));
    }
    if (!chunk.sha256().empty() && !store::IsSha256Hex(chunk.sha256())) {
      return absl::InvalidArgumentError(
          absl::StrCat("artifact.sha256: expected 64 lowercase hex digits, got '", chunk.sha256(), "'"));
    }
    PartialArtifact partial;
    partial.total_size = chunk.total_size();
    partial.sha256 = chunk.sha256();
    partial.bytes.reserve(partial.total_size);
    it = partial_.emplace(name, std::move(partial)).first;
  } else if (chunk.offset() != it->second.bytes.size()) {
    return absl::InvalidArgumentError(absl::StrCat("artifact.offset: expected ", it->second.bytes.size(), " for '",
                                                   name, "', got ", chunk.offset()));
  }
  PartialArtifact& partial = it->second;
  if (partial.bytes.size() + chunk.data().size() > partial.total_size) {
    return absl::InvalidArgumentError(absl::StrCat("artifact.data: '", name, "' would exceed its total_size of ",
                                                   partial.total_size, " bytes"));
  }
  partial.bytes.append(chunk.data());
  if (partial.bytes.size() < partial.total_size) return absl::OkStatus();

  const std::string sha256 = store::Sha256Hex(partial.bytes);
  if (!partial.sha256.empty() && partial.sha256 != sha256) {
    return absl::DataLossError(absl::StrCat("artifact '", name, "': sha256 is ", sha256, ", the first chunk said ",
                                            partial.sha256));
  }
  const int64_t now_ms = service_->clock_();
  absl::StatusOr<store::Artifact> stored = service_->artifacts_.PutBytes(job_id_, name, partial.bytes, now_ms);
  partial_.erase(it);
  if (!stored.ok()) return stored.status();
  v1::JobEvent event;
  event.set_job_id(job_id_);
  event.set_unix_ms(now_ms);
  v1::ArtifactReady* ready = event.mutable_artifact();
  ready->set_name(stored->name);
  ready->set_sha256(stored->sha256);
  ready->set_size(static_cast<uint64_t>(stored->size));
  service_->Emit(std::move(event));
  return absl::OkStatus();
}

// ---------------------------------------------------------------- service

WorkersService::WorkersService(store::JobStore& jobs, store::ArtifactStore& artifacts, Clock clock,
                               WorkersServiceOptions options, JobEventSink on_event)
    : jobs_(jobs),
      artifacts_(artifacts),
      clock_(std::move(clock)),
      options_(options),
      on_event_(std::move(on_event)) {
  if (absl::Status valid = options_.Check(); !valid.ok() || !clock_) {
    // A programmer error: options come from validated flags or config.
    std::fprintf(stderr, "WorkersService: %s\n", valid.ok() ? "clock: required" : valid.ToString().c_str());
    std::abort();
  }
  poller_ = std::thread([this] { ServeParkedPolls(); });
}

WorkersService::~WorkersService() { Stop(); }

void WorkersService::NotifyWork() {
  {
    std::lock_guard<std::mutex> lock(poll_mu_);
    wake_ = true;
  }
  poll_cv_.notify_one();
}

void WorkersService::Stop() {
  {
    std::lock_guard<std::mutex> lock(poll_mu_);
    stopping_ = true;
  }
  poll_cv_.notify_one();
  if (poller_.joinable()) poller_.join();
  // The poller is gone: answer what it left parked.
  std::deque<ParkedPoll> left;
  {
    std::lock_guard<std::mutex> lock(poll_mu_);
    left.swap(parked_);
  }
  for (ParkedPoll& poll : left) poll.reactor->Finish(grpc::Status::OK);
}

std::optional<RegisteredWorker> WorkersService::FindWorker(absl::string_view worker_id) const {
  std::lock_guard<std::mutex> lock(workers_mu_);
  auto it = workers_.find(worker_id);
  if (it == workers_.end()) return std::nullopt;
  return it->second;
}

std::vector<RegisteredWorker> WorkersService::ListWorkers() const {
  std::lock_guard<std::mutex> lock(workers_mu_);
  std::vector<RegisteredWorker> all;
  all.reserve(workers_.size());
  for (const auto& [id, worker] : workers_) all.push_back(worker);
  return all;
}

std::vector<v1::JobEvent> WorkersService::RecordedEvents(absl::string_view job_id) const {
  std::lock_guard<std::mutex> lock(events_mu_);
  auto it = events_.find(job_id);
  if (it == events_.end()) return {};
  return it->second;
}

void WorkersService::ForgetJob(absl::string_view job_id) {
  std::lock_guard<std::mutex> lock(events_mu_);
  auto it = events_.find(job_id);
  if (it != events_.end()) events_.erase(it);
}

absl::Status WorkersService::CheckWorker(absl::string_view worker_id) const {
  if (worker_id.empty()) return absl::InvalidArgumentError("worker_id: required (call RegisterWorker first)");
  std::lock_guard<std::mutex> lock(workers_mu_);
  if (workers_.find(worker_id) == workers_.end()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "worker_id: unknown worker '", worker_id, "' (register again: the server may have restarted)"));
  }
  return absl::OkStatus();
}

grpc::ServerUnaryReactor* WorkersService::RegisterWorker(grpc::CallbackServerContext* context,
                                                         const v1::RegisterWorkerRequest* request,
                                                         v1::RegisterWorkerResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (request->name().empty() || request->name().size() > kMaxWorkerNameChars) {
    reactor->Finish(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                                 absl::StrCat("name: must be 1..", kMaxWorkerNameChars, " characters, got ",
                                              request->name().size())));
    return reactor;
  }
  absl::StatusOr<std::string> id = store::RandomId128();
  if (!id.ok()) {
    reactor->Finish(ToGrpc(id.status()));
    return reactor;
  }
  RegisteredWorker worker;
  worker.id = *id;
  worker.name = request->name();
  worker.gl_renderer = request->gl_renderer();
  worker.threads = request->threads();
  worker.registered_ms = clock_();
  {
    std::lock_guard<std::mutex> lock(workers_mu_);
    workers_[worker.id] = worker;
  }
  response->set_worker_id(worker.id);
  response->set_lease_seconds(static_cast<uint32_t>(options_.lease_seconds));
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

grpc::ServerUnaryReactor* WorkersService::LeaseTask(grpc::CallbackServerContext* context,
                                                    const v1::LeaseTaskRequest* request,
                                                    v1::LeaseTaskResponse* response) {
  if (absl::Status known = CheckWorker(request->worker_id()); !known.ok()) {
    grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
    reactor->Finish(ToGrpc(known));
    return reactor;
  }
  // Every call goes through the poller, which tries the store first: one
  // path for immediate answers and long polls, in arrival order.
  auto* poll = new LeasePoll(this, response);
  const uint32_t wait_seconds =
      std::min(request->wait_seconds(), static_cast<uint32_t>(options_.max_wait_seconds));
  bool parked = false;
  {
    std::lock_guard<std::mutex> lock(poll_mu_);
    if (!stopping_) {
      parked_.push_back(ParkedPoll{poll, request->worker_id(),
                                   std::chrono::steady_clock::now() + std::chrono::seconds(wait_seconds)});
      wake_ = true;
      parked = true;
    }
  }
  // From here the poller may finish the call at any time (gRPC allows that
  // before the reactor is returned; OnDone only runs after both).
  if (parked) {
    poll_cv_.notify_one();
  } else {
    poll->Finish(grpc::Status::OK);  // stopping: nothing will be leased
  }
  return poll;
}

grpc::ServerUnaryReactor* WorkersService::RenewLease(grpc::CallbackServerContext* context,
                                                     const v1::RenewLeaseRequest* request,
                                                     v1::RenewLeaseResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  absl::Status status = CheckWorker(request->worker_id());
  if (status.ok() && request->task_id().empty()) status = absl::InvalidArgumentError("task_id: required");
  const int64_t now_ms = clock_();
  if (status.ok()) status = jobs_.RenewLease(request->task_id(), request->worker_id(), now_ms, lease_ms());
  if (status.ok()) response->set_lease_expires_unix_ms(now_ms + lease_ms());
  reactor->Finish(ToGrpc(status));
  return reactor;
}

grpc::ServerReadReactor<v1::TaskUpdate>* WorkersService::ReportTask(grpc::CallbackServerContext* context,
                                                                    v1::TaskUpdateAck* ack) {
  return new ReportReactor(this, ack);
}

absl::StatusOr<std::optional<v1::Task>> WorkersService::TryLease(const std::string& worker_id) {
  for (int skipped = 0; skipped < kMaxSkippedTasksPerLease; ++skipped) {
    const int64_t now_ms = clock_();
    absl::StatusOr<std::optional<store::Task>> leased = jobs_.LeaseTask(worker_id, now_ms, lease_ms());
    if (!leased.ok()) return leased.status();
    if (!leased->has_value()) return std::nullopt;
    const store::Task& task = **leased;

    absl::StatusOr<store::Job> job = jobs_.GetJob(task.job_id);
    if (!job.ok()) return job.status();
    v1::Task out;
    if (!out.mutable_request()->ParseFromString(job->request)) {
      // Not the worker's fault, and no worker could run it: fail the task
      // (its job fails for good at max_attempts) and look for another.
      const std::string reason =
          absl::StrCat("job ", job->id, ": its stored request is not a valid mvbrdf.v1.SubmitJobRequest");
      absl::Status failed = jobs_.FailTask(task.id, worker_id, reason, now_ms);
      if (!failed.ok()) return failed;
      EmitFinalState(task.job_id);
      continue;
    }
    out.set_id(task.id);
    out.set_job_id(task.job_id);
    out.set_kind(task.kind);
    out.set_key(task.key);
    out.set_bundle_sha256(job->scene_hash);
    out.set_lease_expires_unix_ms(task.lease_expires_ms);

    v1::JobEvent event;
    event.set_job_id(task.job_id);
    event.set_unix_ms(now_ms);
    v1::StageStarted* started = event.mutable_stage_started();
    started->set_stage(task.kind);
    started->set_task_id(task.id);
    started->set_worker(worker_id);
    Emit(std::move(event));
    return out;
  }
  return std::nullopt;
}

void WorkersService::ServeParkedPolls() {
  std::unique_lock<std::mutex> lock(poll_mu_);
  while (!stopping_) {
    if (parked_.empty()) {
      poll_cv_.wait(lock, [this] { return stopping_ || !parked_.empty(); });
      continue;
    }
    if (!wake_) {
      auto next = std::chrono::steady_clock::now() + std::chrono::milliseconds(options_.poll_interval_ms);
      for (const ParkedPoll& poll : parked_) next = std::min(next, poll.deadline);
      poll_cv_.wait_until(lock, next, [this] { return stopping_ || wake_; });
      if (stopping_) break;
    }
    wake_ = false;

    // Serve the parked calls without the lock, so that new calls can park.
    std::deque<ParkedPoll> batch;
    batch.swap(parked_);
    lock.unlock();
    std::deque<ParkedPoll> still_waiting;
    bool store_empty = false;  // nothing leasable: no need to ask again this round
    const auto now = std::chrono::steady_clock::now();
    for (ParkedPoll& poll : batch) {
      if (poll.reactor->cancelled()) {
        poll.reactor->Finish(grpc::Status::CANCELLED);
        continue;
      }
      if (!store_empty) {
        absl::StatusOr<std::optional<v1::Task>> task = TryLease(poll.worker_id);
        if (!task.ok()) {
          poll.reactor->Finish(ToGrpc(task.status()));
          continue;
        }
        if (task->has_value()) {
          *poll.reactor->response()->mutable_task() = std::move(**task);
          poll.reactor->Finish(grpc::Status::OK);
          continue;
        }
        store_empty = true;
      }
      if (now >= poll.deadline) {
        poll.reactor->Finish(grpc::Status::OK);  // nothing within wait_seconds
        continue;
      }
      still_waiting.push_back(std::move(poll));
    }
    lock.lock();
    // Those that waited longest stay first.
    for (ParkedPoll& poll : parked_) still_waiting.push_back(std::move(poll));
    parked_.swap(still_waiting);
  }
}

void WorkersService::Emit(v1::JobEvent event) {
  {
    std::lock_guard<std::mutex> lock(events_mu_);
    std::vector<v1::JobEvent>& record = events_[event.job_id()];
    auto same_stage_progress = [&event](const v1::JobEvent& earlier) {
      return earlier.has_progress() && earlier.progress().stage() == event.progress().stage();
    };
    auto earlier = event.has_progress() ? std::find_if(record.begin(), record.end(), same_stage_progress)
                                        : record.end();
    if (earlier != record.end()) {
      *earlier = event;
    } else {
      record.push_back(event);
    }
  }
  if (on_event_) on_event_(event);
}

void WorkersService::EmitFinalState(const std::string& job_id) {
  absl::StatusOr<store::Job> job = jobs_.GetJob(job_id);
  if (!job.ok() || !store::IsFinal(job->state)) return;
  v1::JobEvent event;
  event.set_job_id(job_id);
  event.set_unix_ms(job->updated_ms);
  switch (job->state) {
    case store::JobState::kSucceeded:
      event.set_state(v1::SUCCEEDED);
      break;
    case store::JobState::kFailed:
      event.set_failed(job->error);
      break;
    case store::JobState::kCancelled:
      event.set_state(v1::CANCELLED);
      break;
    case store::JobState::kQueued:
    case store::JobState::kRunning:
      return;
  }
  Emit(std::move(event));
}

}  // namespace mvbrdf::server
