#include "server/workers_api/workers_service.h"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/samples/sample_set.h"
#include "server/auth/authorize.h"
#include "server/auth/failed_reactor.h"
#include "server/store/digest.h"
#include "server/workers_api/chunk_stream.h"
#include "server/workers_api/sample_key.h"

namespace mvbrdf::server {
namespace {

constexpr size_t kMaxWorkerNameChars = 128;
// Tasks whose job request does not parse are failed and skipped; this many at
// most per lease attempt (each failure bumps the task's attempts, so a bad
// job fails for good after max_attempts anyway).
constexpr int kMaxSkippedTasksPerLease = 16;
// FetchBundle and FetchSamples chunks: well below gRPC's default 4 MiB
// message limit.
constexpr int64_t kFetchChunkBytes = int64_t{1} << 20;
constexpr char kGatherKind[] = "gather";
constexpr char kSweepKind[] = "sweep";

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
  if (max_samples_bytes <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("max_samples_bytes: must be > 0, got ", max_samples_bytes));
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
  ReportReactor(WorkersService* service, v1::TaskUpdateAck* ack, auth::Principal caller)
      : service_(service), ack_(ack), caller_(std::move(caller)) {
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
  // A chunk of the encoded triangle Samples (gather tasks); the same rules
  // as artifact chunks, kept in samples_ until the result.
  absl::Status AddSamplesChunk(const v1::ArtifactChunk& chunk);
  // A gather result: checks it against the Samples received and puts them
  // in the Sample cache.
  absl::Status CacheGatheredSamples(const std::string& result, int64_t now_ms);
  // The server failed to keep what the worker sent (`what`): fails the
  // task's attempt (permanently when storage is full) and returns the
  // error to end the stream with.
  absl::Status FailOnStorage(absl::string_view what, const absl::Status& error, int64_t now_ms);

  WorkersService* const service_;
  v1::TaskUpdateAck* const ack_;
  const auth::Principal caller_;  // who opened the stream
  v1::TaskUpdate update_;
  // Set by the first update; every later one must name the same.
  std::string worker_id_;
  std::string task_id_;
  std::string job_id_;
  std::string task_kind_;
  std::map<std::string, PartialArtifact> partial_;  // by artifact name
  std::optional<PartialArtifact> samples_;          // since the first samples chunk
  bool samples_complete_ = false;                   // and its sha256 verified
};

absl::StatusOr<WorkersService::ReportReactor::Step> WorkersService::ReportReactor::Apply(
    const v1::TaskUpdate& update) {
  if (task_id_.empty()) {
    if (update.task_id().empty()) return absl::InvalidArgumentError("task_id: required");
    MVBRDF_RETURN_IF_ERROR(service_->CheckWorker(update.worker_id(), caller_));
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
  task_kind_ = task->kind;

  const int64_t now_ms = service_->clock_();
  v1::JobEvent event;
  event.set_job_id(job_id_);
  event.set_unix_ms(now_ms);
  switch (update.update_case()) {
    case v1::TaskUpdate::kProgress:
      *event.mutable_progress() = update.progress();
      service_->Emit(std::move(event));
      return Step::kNext;
    case v1::TaskUpdate::kStageFinished: {
      // Which task, on which worker: one event says it all (issue #20). Kept
      // with the task, so that a watch replays it with its numbers.
      v1::StageFinished* finished = event.mutable_stage_finished();
      *finished = update.stage_finished();
      finished->set_key(task->key);
      finished->set_task_id(task_id_);
      finished->set_worker_name(service_->WorkerName(worker_id_));
      absl::Status kept = service_->jobs_.SetStageFinished(task_id_, worker_id_, finished->SerializeAsString());
      if (absl::IsFailedPrecondition(kept)) return Step::kLeaseLost;
      if (!kept.ok()) return kept;
      service_->Emit(std::move(event));
      return Step::kNext;
    }
    case v1::TaskUpdate::kArtifact: {
      absl::Status added = AddChunk(update.artifact_name(), update.artifact());
      if (!added.ok()) return added;
      return Step::kNext;
    }
    case v1::TaskUpdate::kSamples: {
      absl::Status added = AddSamplesChunk(update.samples());
      if (!added.ok()) return added;
      return Step::kNext;
    }
    case v1::TaskUpdate::kResult: {
      if (!partial_.empty()) {
        const auto& [name, partial] = *partial_.begin();
        return absl::InvalidArgumentError(absl::StrCat("result: artifact '", name, "' is incomplete (",
                                                       partial.bytes.size(), " of ", partial.total_size, " bytes)"));
      }
      if (samples_.has_value() && !samples_complete_) {
        return absl::InvalidArgumentError(absl::StrCat("result: the samples are incomplete (",
                                                       samples_->bytes.size(), " of ", samples_->total_size,
                                                       " bytes)"));
      }
      if (task_kind_ == kGatherKind) {
        absl::Status cached = CacheGatheredSamples(update.result(), now_ms);
        if (!cached.ok()) return cached;
      }
      absl::Status completed = service_->jobs_.CompleteTask(task_id_, worker_id_, update.result(), now_ms);
      if (absl::IsFailedPrecondition(completed)) return Step::kLeaseLost;
      if (!completed.ok()) return completed;
      service_->NotifyWork();  // dependents may be leasable now
      service_->EmitFinalState(job_id_);
      return Step::kAccepted;
    }
    case v1::TaskUpdate::kFailed: {
      // The job's error says which worker failed and why ("on worker ID
      // (NAME)"), so one bad worker among healthy ones can be found.
      std::optional<RegisteredWorker> worker = service_->FindWorker(worker_id_);
      const std::string reason = absl::StrCat(
          update.failed().empty() ? "the worker gave no reason" : update.failed(), " (on worker ", worker_id_,
          worker.has_value() ? absl::StrCat(" \"", worker->name, "\"") : "",
          update.worker_fault() && !update.permanent() ? ", a failure of the worker's own environment" : "", ")");
      absl::Status failed =
          service_->jobs_.FailTask(task_id_, worker_id_, reason, now_ms, update.permanent(), update.worker_fault());
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
      "update: one of progress, stage_finished, artifact, samples, result or failed is required");
}

absl::StatusOr<WorkersService::ReportReactor::Step> WorkersService::ReportReactor::EndOfStream() const {
  if (task_id_.empty()) return absl::InvalidArgumentError("ReportTask: the stream had no updates");
  if (!partial_.empty()) {
    const auto& [name, partial] = *partial_.begin();
    return absl::InvalidArgumentError(absl::StrCat("artifact '", name, "': the stream ended after ",
                                                   partial.bytes.size(), " of ", partial.total_size, " bytes"));
  }
  if (samples_.has_value() && !samples_complete_) {
    return absl::InvalidArgumentError(absl::StrCat("samples: the stream ended after ", samples_->bytes.size(),
                                                   " of ", samples_->total_size, " bytes"));
  }
  return Step::kAccepted;
}

absl::Status WorkersService::ReportReactor::AddSamplesChunk(const v1::ArtifactChunk& chunk) {
  if (task_kind_ != kGatherKind) {
    return absl::InvalidArgumentError(
        absl::StrCat("samples: only a gather task sends Samples; task ", task_id_, " is a ", task_kind_, " task"));
  }
  if (samples_complete_) {
    return absl::InvalidArgumentError("samples: already complete; a stream sends the Samples once");
  }
  if (!samples_.has_value()) {
    if (chunk.offset() != 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("samples.offset: the first chunk must start at 0, got ", chunk.offset()));
    }
    if (chunk.total_size() > static_cast<uint64_t>(service_->options_.max_samples_bytes)) {
      return absl::ResourceExhaustedError(absl::StrCat("samples.total_size: ", chunk.total_size(),
                                                       " bytes exceed the limit of ",
                                                       service_->options_.max_samples_bytes));
    }
    if (!store::IsSha256Hex(chunk.sha256())) {
      return absl::InvalidArgumentError(absl::StrCat(
          "samples.sha256: the first chunk needs 64 lowercase hex digits, got '", chunk.sha256(), "'"));
    }
    PartialArtifact partial;
    partial.total_size = chunk.total_size();
    partial.sha256 = chunk.sha256();
    partial.bytes.reserve(partial.total_size);
    samples_ = std::move(partial);
  } else if (chunk.offset() != samples_->bytes.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("samples.offset: expected ", samples_->bytes.size(), ", got ", chunk.offset()));
  }
  PartialArtifact& partial = *samples_;
  if (partial.bytes.size() + chunk.data().size() > partial.total_size) {
    return absl::InvalidArgumentError(
        absl::StrCat("samples.data: would exceed total_size of ", partial.total_size, " bytes"));
  }
  partial.bytes.append(chunk.data());
  if (partial.bytes.size() < partial.total_size) return absl::OkStatus();
  const std::string sha256 = store::Sha256Hex(partial.bytes);
  if (sha256 != partial.sha256) {
    absl::Status mismatch = absl::DataLossError(
        absl::StrCat("samples: sha256 is ", sha256, ", the first chunk said ", partial.sha256));
    samples_.reset();  // `partial` is gone from here on
    return mismatch;
  }
  samples_complete_ = true;
  return absl::OkStatus();
}

absl::Status WorkersService::ReportReactor::CacheGatheredSamples(const std::string& result, int64_t now_ms) {
  if (!samples_complete_) {
    return absl::InvalidArgumentError("samples: a gather result needs the encoded Samples first");
  }
  v1::GatherResult gathered;
  if (!gathered.ParseFromString(result)) {
    return absl::InvalidArgumentError("result: a gather result must be an encoded mvbrdf.v1.GatherResult");
  }
  if (gathered.samples_sha256() != samples_->sha256) {
    return absl::InvalidArgumentError(absl::StrCat("result.samples_sha256: '", gathered.samples_sha256(),
                                                   "' is not the sha256 of the Samples sent (",
                                                   samples_->sha256, ")"));
  }
  MVBRDF_ASSIGN_OR_RETURN(store::Job job, service_->jobs_.GetJob(job_id_));
  MVBRDF_ASSIGN_OR_RETURN(v1::SubmitJobRequest request, RequestOf(job));
  const store::SampleKey key = TriangleSampleKey(job.scene_hash, request);
  // Pinned for the job: its sweeps and texel passes fetch them later.
  absl::Status put = service_->samples_.Put(key, samples_->bytes, now_ms, samples_->sha256, job.id);  // verified above
  if (!put.ok()) {
    return FailOnStorage(absl::StrCat("samples: ", samples_->bytes.size(), " bytes of triangle Samples"), put, now_ms);
  }
  // The cameras the Samples were resampled with (issue #14), for a gather
  // answered from the cache.
  put = service_->samples_.Put(CalibrationKey(job.scene_hash, request), gathered.calibration().SerializeAsString(),
                               now_ms, {}, job.id);
  if (put.ok()) return put;
  return FailOnStorage("result.calibration: the camera refinement", put, now_ms);
}

absl::Status WorkersService::ReportReactor::FailOnStorage(absl::string_view what, const absl::Status& error,
                                                          int64_t now_ms) {
  // The worker's output was fine; the server could not keep it (disk full,
  // an I/O error, the cache's limit). Letting the lease run out would only
  // rerun the task and end in "lease expired", which says nothing. Fail this
  // attempt now and say why. A full disk or a full cache fails the task and
  // its job at once (any worker would repeat it until an operator frees
  // space; the Sample cache keeps a finished gather for the resubmission);
  // other storage errors leave the usual attempts.
  const bool full = absl::IsResourceExhausted(error);
  const std::string reason =
      absl::StrCat("server: cannot store ", what, (full ? " (the server's storage is full)" : ""), ": ",
                   error.message());
  (void)service_->jobs_.FailTask(task_id_, worker_id_, reason, now_ms, /*permanent=*/full);
  service_->NotifyWork();
  service_->EmitFinalState(job_id_);
  return absl::Status(error.code(), reason);
}

absl::Status WorkersService::ReportReactor::AddChunk(const std::string& name, const v1::ArtifactChunk& chunk) {
  if (name.empty()) return absl::InvalidArgumentError("artifact_name: required with an artifact chunk");
  {
    // Clients write artifacts to DIR/name (`fetch`, `run`): the name must be
    // a relative, normalised path without "..", whatever a worker sends.
    const std::filesystem::path path(name);
    bool parent = false;
    for (const std::filesystem::path& part : path) parent = parent || part == "..";
    if (name.size() > 256 || path.is_absolute() || parent || path.lexically_normal() != path) {
      return absl::InvalidArgumentError(absl::StrCat("artifact_name: must be a relative, normalised path of at most ",
                                                     "256 characters without \"..\", got \"", name.substr(0, 300),
                                                     "\""));
    }
  }
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
  const size_t size = partial.bytes.size();
  partial_.erase(it);
  if (!stored.ok()) {
    return FailOnStorage(absl::StrCat("artifact '", name, "' (", size, " bytes)"), stored.status(), now_ms);
  }
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

WorkersService::WorkersService(store::JobStore& jobs, store::ArtifactStore& artifacts, store::SampleCache& samples,
                               BundlePath bundle_path, Clock clock, WorkersServiceOptions options,
                               JobEventSink on_event)
    : jobs_(jobs),
      artifacts_(artifacts),
      samples_(samples),
      bundle_path_(std::move(bundle_path)),
      clock_(std::move(clock)),
      options_(options),
      on_event_(std::move(on_event)) {
  absl::Status valid = options_.Check();
  if (valid.ok() && !clock_) valid = absl::InvalidArgumentError("clock: required");
  if (valid.ok() && !bundle_path_) valid = absl::InvalidArgumentError("bundle_path: required");
  if (!valid.ok()) {
    // A programmer error: options come from validated flags or config.
    std::fprintf(stderr, "WorkersService: %s\n", valid.ToString().c_str());
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

std::string WorkersService::WorkerName(absl::string_view worker_id) const {
  std::optional<RegisteredWorker> worker = FindWorker(worker_id);
  return worker.has_value() ? worker->name : std::string();
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

absl::StatusOr<auth::Principal> WorkersService::CheckCaller(const grpc::CallbackServerContext& context) const {
  return auth::Authorize(context, options_.tokens.get(), auth::Role::kWorker);
}

absl::Status WorkersService::CheckWorker(absl::string_view worker_id, const auth::Principal& caller) const {
  if (worker_id.empty()) return absl::InvalidArgumentError("worker_id: required (call RegisterWorker first)");
  std::lock_guard<std::mutex> lock(workers_mu_);
  auto it = workers_.find(worker_id);
  if (it == workers_.end()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "worker_id: unknown worker '", worker_id, "' (register again: the server may have restarted)"));
  }
  // A worker id is a handle, not a credential: only the token that
  // registered it (or an admin) may act as that worker.
  if (caller.authenticated && caller.role != auth::Role::kAdmin && it->second.principal != caller.name) {
    return absl::PermissionDeniedError(
        absl::StrCat("worker_id: worker '", worker_id, "' was registered with another token"));
  }
  return absl::OkStatus();
}

grpc::ServerUnaryReactor* WorkersService::RegisterWorker(grpc::CallbackServerContext* context,
                                                         const v1::RegisterWorkerRequest* request,
                                                         v1::RegisterWorkerResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  absl::StatusOr<auth::Principal> caller = CheckCaller(*context);
  if (!caller.ok()) {
    reactor->Finish(ToGrpc(caller.status()));
    return reactor;
  }
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
  if (caller->authenticated) worker.principal = caller->name;
  // The name outlives this registration in the store: tasks name their worker.
  if (absl::Status kept = jobs_.RegisterWorker(worker.id, worker.name, worker.registered_ms); !kept.ok()) {
    reactor->Finish(ToGrpc(kept));
    return reactor;
  }
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
  absl::StatusOr<auth::Principal> caller = CheckCaller(*context);
  absl::Status known = caller.ok() ? CheckWorker(request->worker_id(), *caller) : caller.status();
  if (!known.ok()) {
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
  absl::StatusOr<auth::Principal> caller = CheckCaller(*context);
  absl::Status status = caller.ok() ? CheckWorker(request->worker_id(), *caller) : caller.status();
  if (status.ok() && request->task_id().empty()) status = absl::InvalidArgumentError("task_id: required");
  const int64_t now_ms = clock_();
  if (status.ok()) status = jobs_.RenewLease(request->task_id(), request->worker_id(), now_ms, lease_ms());
  if (status.ok()) response->set_lease_expires_unix_ms(now_ms + lease_ms());
  reactor->Finish(ToGrpc(status));
  return reactor;
}

grpc::ServerReadReactor<v1::TaskUpdate>* WorkersService::ReportTask(grpc::CallbackServerContext* context,
                                                                    v1::TaskUpdateAck* ack) {
  absl::StatusOr<auth::Principal> caller = CheckCaller(*context);
  if (!caller.ok()) return new auth::FailedReadReactor<v1::TaskUpdate>(caller.status());
  return new ReportReactor(this, ack, *std::move(caller));
}

grpc::ServerWriteReactor<v1::ArtifactChunk>* WorkersService::FetchBundle(grpc::CallbackServerContext* context,
                                                                          const v1::FetchBundleRequest* request) {
  absl::StatusOr<auth::Principal> caller = CheckCaller(*context);
  if (!caller.ok()) return ChunkStream::Failed(caller.status());
  if (absl::Status known = CheckWorker(request->worker_id(), *caller); !known.ok()) return ChunkStream::Failed(known);
  if (!store::IsSha256Hex(request->sha256())) {
    return ChunkStream::Failed(absl::InvalidArgumentError(absl::StrCat(
        "sha256: must be 64 lowercase hex digits (a SHA-256), got \"", request->sha256().substr(0, 80), "\"")));
  }
  const std::filesystem::path path = bundle_path_(request->sha256());
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return ChunkStream::Failed(absl::NotFoundError(
        absl::StrCat("sha256: the server has no complete bundle ", request->sha256(), " (upload it first)")));
  }
  // The file was renamed into place only after its hash was verified, so
  // its name is its digest: no need to hash gigabytes again here.
  return ChunkStream::FromFile(path, request->sha256(), kFetchChunkBytes);
}

grpc::ServerWriteReactor<v1::ArtifactChunk>* WorkersService::FetchSamples(grpc::CallbackServerContext* context,
                                                                           const v1::FetchSamplesRequest* request) {
  absl::StatusOr<auth::Principal> caller = CheckCaller(*context);
  if (!caller.ok()) return ChunkStream::Failed(caller.status());
  if (absl::Status known = CheckWorker(request->worker_id(), *caller); !known.ok()) return ChunkStream::Failed(known);
  if (request->task_id().empty()) return ChunkStream::Failed(absl::InvalidArgumentError("task_id: required"));
  absl::StatusOr<store::Task> task = jobs_.GetTask(request->task_id());
  if (!task.ok()) return ChunkStream::Failed(task.status());
  absl::StatusOr<store::Job> job = jobs_.GetJob(task->job_id);
  if (!job.ok()) return ChunkStream::Failed(job.status());
  if (store::IsFinal(job->state)) {
    return ChunkStream::Failed(absl::FailedPreconditionError(
        absl::StrCat("task_id: job ", job->id, " of task ", task->id, " is ", store::JobStateName(job->state))));
  }
  if (task->state != store::TaskState::kLeased || task->lease_owner != request->worker_id()) {
    return ChunkStream::Failed(absl::FailedPreconditionError(absl::StrCat(
        "task_id: task ", task->id, " is not leased by worker ", request->worker_id(), " (Samples go to the lease holder)")));
  }
  absl::StatusOr<v1::SubmitJobRequest> parsed = RequestOf(*job);
  if (!parsed.ok()) return ChunkStream::Failed(parsed.status());
  const store::SampleKey key = TriangleSampleKey(job->scene_hash, *parsed);
  // The digest Get verified (or kept with its copy in memory): not hashed again.
  std::string sha256;
  absl::StatusOr<std::optional<std::string>> bytes = samples_.Get(key, clock_(), &sha256);
  if (bytes.ok() && bytes->has_value()) {
    return ChunkStream::FromBytes(std::move(**bytes), std::move(sha256), kFetchChunkBytes);
  }
  // DATA_LOSS: the entry failed its checksum and the cache dropped it; empty:
  // evicted (or dropped) since the gather. Either way the gather runs again.
  if (!bytes.ok() && !absl::IsDataLoss(bytes.status())) return ChunkStream::Failed(bytes.status());
  return ChunkStream::Failed(RegatherFor(*task, request->worker_id(), key,
                                         bytes.ok() ? "evicted from the Sample cache"
                                                    : std::string(bytes.status().message())));
}

absl::Status WorkersService::RegatherFor(const store::Task& task, const std::string& worker_id,
                                         const store::SampleKey& key, const std::string& why) {
  auto gather = std::find_if(task.depends_on.begin(), task.depends_on.end(), [&](const std::string& id) {
    absl::StatusOr<store::Task> dependency = jobs_.GetTask(id);
    return dependency.ok() && dependency->kind == kGatherKind;
  });
  if (gather == task.depends_on.end()) {
    return absl::NotFoundError(absl::StrCat("no cached Samples for ", key.ToString(), " (", why, ")"));
  }
  const std::string reason = absl::StrCat("the Samples ", key.ToString(), " were lost (", why, "); gathering again");
  MVBRDF_RETURN_IF_ERROR(jobs_.RedoDependency(task.id, worker_id, *gather, reason, clock_()));
  NotifyWork();
  EmitFinalState(task.job_id);  // when the gather had used its attempts, the job failed
  return absl::AbortedError(absl::StrCat(reason, "; task ", task.id, " is queued behind the gather"));
}

absl::StatusOr<v1::SubmitJobRequest> WorkersService::RequestOf(const store::Job& job) {
  v1::SubmitJobRequest request;
  if (!request.ParseFromString(job.request)) {
    return absl::InternalError(
        absl::StrCat("job ", job.id, ": its stored request is not a valid mvbrdf.v1.SubmitJobRequest"));
  }
  return request;
}

absl::Status WorkersService::FillInputs(const store::Task& task, v1::Task& out) {
  for (const std::string& dependency_id : task.depends_on) {
    MVBRDF_ASSIGN_OR_RETURN(store::Task dependency, jobs_.GetTask(dependency_id));
    v1::TaskInput* input = out.add_inputs();
    input->set_task_id(dependency.id);
    input->set_kind(dependency.kind);
    input->set_key(dependency.key);
    // Leasable means every dependency is done, so each has its result.
    input->set_result(dependency.result.value_or(""));
    input->set_started_unix_ms(dependency.started_ms);
    input->set_finished_unix_ms(dependency.updated_ms);
  }
  return absl::OkStatus();
}

absl::StatusOr<bool> WorkersService::AnswerGatherFromCache(const store::Task& task, const std::string& worker_id,
                                                           const store::Job& job,
                                                           const v1::SubmitJobRequest& request) {
  const int64_t now_ms = clock_();
  const store::SampleKey key = TriangleSampleKey(job.scene_hash, request);
  // DATA_LOSS: the entry was corrupt and is gone. Any other cache error: the
  // cache is an optimisation, the worker can always resample.
  std::string sha256;
  absl::StatusOr<std::optional<std::string>> bytes = samples_.Get(key, now_ms, &sha256);
  if (!bytes.ok() || !bytes->has_value()) return false;
  // The header alone (its counts checked against the size): the Samples are
  // decoded by the tasks that use them, not here on the poller thread.
  absl::StatusOr<samples::SampleSetHeader> decoded = samples::ReadSampleSetHeader(**bytes);
  if (!decoded.ok()) {
    // Intact bytes (the checksum held) of a foreign or outdated encoding:
    // useless to every sweep, so drop them and resample.
    (void)samples_.Erase(key);
    return false;
  }
  // The camera refinement they were resampled with (issue #14): without it
  // the later tasks would not know the cameras, so it is a miss.
  v1::GatherResult result;
  {
    absl::StatusOr<std::optional<std::string>> calibration =
        samples_.Get(CalibrationKey(job.scene_hash, request), now_ms);
    if (!calibration.ok() || !calibration->has_value() ||
        !result.mutable_calibration()->ParseFromString(**calibration)) {
      return false;
    }
  }
  // The job's later tasks fetch these: keep them from eviction until it ends.
  // (A failed pin costs at most a regather, RedoDependency's case.)
  (void)samples_.Pin(key, job.id);
  (void)samples_.Pin(CalibrationKey(job.scene_hash, request), job.id);
  result.set_samples_sha256(sha256);
  result.set_samples(decoded->num_samples);
  result.set_encoded_bytes((*bytes)->size());
  result.set_from_cache(true);
  result.set_seconds(0.0);
  v1::StageFinished finished;
  finished.set_stage(kGatherKind);
  finished.set_seconds(0.0);
  (*finished.mutable_metrics())["samples_from_cache"] = 1.0;
  finished.set_key(task.key);
  finished.set_task_id(task.id);
  finished.set_worker_name(WorkerName(worker_id));
  absl::Status kept = jobs_.SetStageFinished(task.id, worker_id, finished.SerializeAsString());
  absl::Status completed =
      kept.ok() ? jobs_.CompleteTask(task.id, worker_id, result.SerializeAsString(), now_ms) : kept;
  if (absl::IsFailedPrecondition(completed)) return true;  // cancelled meanwhile: nothing left to run
  MVBRDF_RETURN_IF_ERROR(completed);
  MVBRDF_RETURN_IF_ERROR(jobs_.SetSamplesFromCache(task.id, true));

  v1::JobEvent event;
  event.set_job_id(task.job_id);
  event.set_unix_ms(now_ms);
  v1::StageStarted* started = event.mutable_stage_started();
  started->set_stage(kGatherKind);
  started->set_task_id(task.id);
  started->set_worker(worker_id);
  started->set_worker_name(finished.worker_name());
  started->set_key(task.key);
  Emit(event);
  event.clear_stage_started();
  *event.mutable_stage_finished() = std::move(finished);
  Emit(std::move(event));
  NotifyWork();  // the sweeps are leasable now
  EmitFinalState(task.job_id);
  return true;
}

absl::StatusOr<std::optional<v1::Task>> WorkersService::TryLease(const std::string& worker_id) {
  // Skips are bounded; cache answers are not: each completes a task, so the
  // loop ends when the store runs out of leasable tasks.
  int skipped = 0;
  while (skipped < kMaxSkippedTasksPerLease) {
    const int64_t now_ms = clock_();
    absl::StatusOr<std::optional<store::Task>> leased = jobs_.LeaseTask(worker_id, now_ms, lease_ms());
    if (!leased.ok()) return leased.status();
    if (!leased->has_value()) return std::nullopt;
    const store::Task& task = **leased;

    absl::StatusOr<store::Job> job = jobs_.GetJob(task.job_id);
    if (!job.ok()) return job.status();
    absl::StatusOr<v1::SubmitJobRequest> request = RequestOf(*job);
    if (!request.ok()) {
      // Not the worker's fault, and no worker could run it: fail the task
      // and its job for good, and look for another.
      absl::Status failed = jobs_.FailTask(task.id, worker_id, request.status().message(), now_ms, /*permanent=*/true);
      if (!failed.ok()) return failed;
      EmitFinalState(task.job_id);
      ++skipped;
      continue;
    }
    if (task.kind == kGatherKind) {
      MVBRDF_ASSIGN_OR_RETURN(bool answered, AnswerGatherFromCache(task, worker_id, *job, *request));
      if (answered) continue;
    }

    v1::Task out;
    *out.mutable_request() = *std::move(request);
    out.set_id(task.id);
    out.set_job_id(task.job_id);
    out.set_kind(task.kind);
    out.set_key(task.key);
    out.set_bundle_sha256(job->scene_hash);
    out.set_lease_expires_unix_ms(task.lease_expires_ms);
    MVBRDF_RETURN_IF_ERROR(FillInputs(task, out));
    if (task.kind == kSweepKind) {
      for (const v1::TaskInput& input : out.inputs()) {
        v1::GatherResult gathered;
        if (input.kind() == kGatherKind && gathered.ParseFromString(input.result()) && gathered.from_cache()) {
          MVBRDF_RETURN_IF_ERROR(jobs_.SetSamplesFromCache(task.id, true));
        }
      }
    }

    v1::JobEvent event;
    event.set_job_id(task.job_id);
    event.set_unix_ms(now_ms);
    v1::StageStarted* started = event.mutable_stage_started();
    started->set_stage(task.kind);
    started->set_task_id(task.id);
    started->set_worker(worker_id);
    started->set_worker_name(WorkerName(worker_id));
    started->set_key(task.key);
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
