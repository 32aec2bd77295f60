#include "server/clients_api/mvbrdf_service.h"

#include <algorithm>
#include <fstream>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/scene/sequence.h"
#include "server/auth/authorize.h"
#include "server/auth/failed_reactor.h"
#include "server/clients_api/job_graph.h"
#include "server/clients_api/job_proto.h"

namespace mvbrdf::clients_api {
namespace {

constexpr int64_t kArtifactChunkBytes = int64_t{1} << 20;
// Room for an ArtifactChunk's other fields below max_message_bytes.
constexpr int64_t kChunkOverheadBytes = 1024;

grpc::Status Error(grpc::StatusCode code, std::string message) { return grpc::Status(code, std::move(message)); }

// One UploadBundle call: the first chunk names the bundle and its size; every
// chunk continues at the bytes received so far, which are appended to the
// .part file at once (so a broken upload resumes where it stopped).
class UploadReactor final : public grpc::ServerReadReactor<v1::UploadChunk> {
 public:
  UploadReactor(BundleArea& area, const ServiceLimits& limits, v1::UploadStatus* response)
      : area_(area), limits_(limits), response_(response) {
    StartRead(&chunk_);
  }

  void OnReadDone(bool ok) override {
    if (!ok) {  // the client closed the stream (or went away)
      Done(sha256_.empty() ? Error(grpc::StatusCode::INVALID_ARGUMENT, "sha256: the upload sent no chunk")
                           : Answer(false));
      return;
    }
    grpc::Status status = Take(chunk_);
    if (!status.ok()) {
      Done(status);
    } else if (complete_) {
      Done(Answer(true));
    } else {
      StartRead(&chunk_);
    }
  }

  void OnDone() override { delete this; }

 private:
  // Releases the upload before answering, so that a client resuming right
  // after the answer finds it free.
  void Done(const grpc::Status& status) {
    if (claimed_) area_.Release(sha256_);
    claimed_ = false;
    Finish(status);
  }

  grpc::Status Answer(bool complete) {
    response_->set_sha256(sha256_);
    response_->set_received_bytes(static_cast<uint64_t>(received_));
    response_->set_complete(complete);
    return grpc::Status::OK;
  }

  grpc::Status Begin(const v1::UploadChunk& chunk) {
    if (absl::Status s = BundleArea::CheckDigest("sha256", chunk.sha256()); !s.ok()) return ToGrpc(s);
    if (chunk.total_size() == 0) return Error(grpc::StatusCode::INVALID_ARGUMENT, "total_size: must be > 0");
    if (chunk.total_size() > static_cast<uint64_t>(limits_.max_bundle_bytes)) {
      return Error(grpc::StatusCode::RESOURCE_EXHAUSTED,
                   absl::StrCat("total_size: ", chunk.total_size(), " bytes exceeds the limit of ",
                                limits_.max_bundle_bytes, " bytes per bundle"));
    }
    sha256_ = chunk.sha256();
    total_ = static_cast<int64_t>(chunk.total_size());
    if (!area_.Claim(sha256_)) {
      return Error(grpc::StatusCode::ABORTED,
                   absl::StrCat("sha256: an upload of ", sha256_, " is in progress; query it and resume later"));
    }
    claimed_ = true;
    absl::StatusOr<UploadProgress> progress = area_.Progress(sha256_);
    if (!progress.ok()) return ToGrpc(progress.status());
    received_ = progress->received_bytes;
    complete_ = progress->complete;  // stored once: nothing more to do
    if (!complete_ && received_ > total_) {
      return Error(grpc::StatusCode::INVALID_ARGUMENT,
                   absl::StrCat("total_size: ", total_, " bytes, but ", received_, " were already received"));
    }
    return grpc::Status::OK;
  }

  grpc::Status Take(const v1::UploadChunk& chunk) {
    if (sha256_.empty()) {
      grpc::Status begun = Begin(chunk);
      if (!begun.ok() || complete_) return begun;
    } else if (!chunk.sha256().empty() && chunk.sha256() != sha256_) {
      return Error(grpc::StatusCode::INVALID_ARGUMENT, "sha256: a later chunk names another bundle");
    }
    const int64_t size = static_cast<int64_t>(chunk.data().size());
    if (chunk.offset() != static_cast<uint64_t>(received_)) {
      return Error(grpc::StatusCode::FAILED_PRECONDITION,
                   absl::StrCat("offset: expected ", received_, " (the bytes received so far), got ", chunk.offset()));
    }
    if (size > limits_.max_message_bytes) {
      // The same code the transport gives a message over its limit.
      return Error(grpc::StatusCode::RESOURCE_EXHAUSTED,
                   absl::StrCat("data: ", size, " bytes in one chunk, at most ", limits_.max_message_bytes));
    }
    if (received_ + size > total_) {
      return Error(grpc::StatusCode::INVALID_ARGUMENT,
                   absl::StrCat("data: the chunk at offset ", received_, " with ", size,
                                " bytes runs past total_size ", total_));
    }
    if (size > 0) {
      if (absl::Status s = area_.Append(sha256_, received_, chunk.data()); !s.ok()) return ToGrpc(s);
      received_ += size;
    }
    if (received_ == total_) {
      if (absl::Status s = area_.Commit(sha256_); !s.ok()) {
        if (s.code() == absl::StatusCode::kInvalidArgument) received_ = 0;  // the .part was dropped
        return ToGrpc(s);
      }
      complete_ = true;
    }
    return grpc::Status::OK;
  }

  BundleArea& area_;
  const ServiceLimits& limits_;
  v1::UploadStatus* const response_;
  v1::UploadChunk chunk_;
  std::string sha256_;  // set by the first chunk
  int64_t total_ = 0;
  int64_t received_ = 0;
  bool claimed_ = false;
  bool complete_ = false;
};

// One FetchArtifact call: the verified file in chunks, the first with the
// size and digest.
class FetchReactor final : public grpc::ServerWriteReactor<v1::ArtifactChunk> {
 public:
  FetchReactor(store::ArtifactStore& artifacts, const v1::FetchArtifactRequest& request, int64_t chunk_bytes)
      : chunk_bytes_(chunk_bytes) {
    grpc::Status opened = Open(artifacts, request);
    if (!opened.ok()) {
      Finish(opened);
      return;
    }
    WriteNext();
  }

  void OnWriteDone(bool ok) override {
    if (!ok) {
      Finish(Error(grpc::StatusCode::CANCELLED, "the fetch ended"));
    } else if (offset_ >= total_) {
      Finish(grpc::Status::OK);
    } else {
      WriteNext();
    }
  }

  void OnDone() override { delete this; }

 private:
  grpc::Status Open(store::ArtifactStore& artifacts, const v1::FetchArtifactRequest& request) {
    absl::StatusOr<std::vector<store::Artifact>> listed = artifacts.ArtifactsOfJob(request.job_id());
    if (!listed.ok()) return ToGrpc(listed.status());
    auto it = std::find_if(listed->begin(), listed->end(),
                           [&](const store::Artifact& a) { return a.name == request.name(); });
    if (it == listed->end()) {
      return Error(grpc::StatusCode::NOT_FOUND,
                   absl::StrCat("name: job ", request.job_id(), " has no artifact \"", request.name(), "\""));
    }
    absl::StatusOr<std::filesystem::path> path = artifacts.OpenVerified(it->sha256);
    if (!path.ok()) return ToGrpc(path.status());
    in_.open(*path, std::ios::binary);
    if (!in_) return Error(grpc::StatusCode::INTERNAL, absl::StrCat(path->string(), ": cannot open"));
    sha256_ = it->sha256;
    total_ = it->size;
    return grpc::Status::OK;
  }

  void WriteNext() {
    const int64_t n = std::min(chunk_bytes_, total_ - offset_);
    chunk_.Clear();
    chunk_.set_offset(static_cast<uint64_t>(offset_));
    if (offset_ == 0) {
      chunk_.set_total_size(static_cast<uint64_t>(total_));
      chunk_.set_sha256(sha256_);
    }
    std::string* data = chunk_.mutable_data();
    data->resize(static_cast<size_t>(n));
    in_.read(data->data(), static_cast<std::streamsize>(n));
    if (in_.gcount() != n) {
      Finish(Error(grpc::StatusCode::DATA_LOSS, absl::StrCat("artifact ", sha256_, ": short read")));
      return;
    }
    offset_ += n;
    StartWrite(&chunk_);
  }

  const int64_t chunk_bytes_;
  std::ifstream in_;
  std::string sha256_;
  int64_t total_ = 0;
  int64_t offset_ = 0;
  v1::ArtifactChunk chunk_;
};

}  // namespace

absl::Status ServiceLimits::Check() const {
  if (max_bundle_bytes <= 0) return absl::InvalidArgumentError("max_bundle_bytes: must be > 0");
  if (max_jobs_per_client < 0) return absl::InvalidArgumentError("max_jobs_per_client: must be >= 0");
  if (max_message_bytes <= kChunkOverheadBytes) {
    return absl::InvalidArgumentError(absl::StrCat("max_message_bytes: must be > ", kChunkOverheadBytes));
  }
  if (watch_poll_ms <= 0) return absl::InvalidArgumentError("watch_poll_ms: must be > 0");
  if (max_atlas_size < 16) {
    return absl::InvalidArgumentError(absl::StrCat("max_atlas_size: must be >= 16, got ", max_atlas_size));
  }
  if (max_frames < 1) return absl::InvalidArgumentError(absl::StrCat("max_frames: must be >= 1, got ", max_frames));
  return absl::OkStatus();
}

MvbrdfService::MvbrdfService(store::JobStore& jobs, store::ArtifactStore& artifacts, std::filesystem::path data_dir,
                             std::function<int64_t()> clock, ServiceLimits limits, std::function<void()> notify_work,
                             std::shared_ptr<const auth::TokenTable> tokens)
    : jobs_(jobs),
      artifacts_(artifacts),
      clock_(std::move(clock)),
      limits_(limits),
      notify_work_(std::move(notify_work)),
      tokens_(std::move(tokens)),
      bundles_(std::move(data_dir)),
      watchers_(jobs, clock_, std::chrono::milliseconds(limits.watch_poll_ms)) {}

absl::StatusOr<auth::Principal> MvbrdfService::Caller(const grpc::CallbackServerContext& context) const {
  return auth::Authorize(context, tokens_.get(), auth::Role::kClient);
}

absl::Status MvbrdfService::CheckJobAccess(const auth::Principal& caller, const std::string& job_id) {
  if (!caller.authenticated || caller.role == auth::Role::kAdmin) return absl::OkStatus();
  absl::StatusOr<store::Job> job = jobs_.GetJob(job_id);
  if (!job.ok()) return job.status();
  if (!auth::MayAccessJob(caller, job->client)) {
    return absl::NotFoundError(absl::StrCat("job ", job_id, ": no such job"));  // as JobStore says
  }
  return absl::OkStatus();
}

grpc::ServerReadReactor<v1::UploadChunk>* MvbrdfService::UploadBundle(grpc::CallbackServerContext* context,
                                                                      v1::UploadStatus* response) {
  if (absl::StatusOr<auth::Principal> caller = Caller(*context); !caller.ok()) {
    return new auth::FailedReadReactor<v1::UploadChunk>(caller.status());
  }
  return new UploadReactor(bundles_, limits_, response);
}

grpc::ServerUnaryReactor* MvbrdfService::QueryUpload(grpc::CallbackServerContext* context,
                                                     const v1::QueryUploadRequest* request,
                                                     v1::UploadStatus* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  absl::Status status = Caller(*context).status();
  if (status.ok()) status = BundleArea::CheckDigest("sha256", request->sha256());
  if (status.ok()) {
    absl::StatusOr<UploadProgress> progress = bundles_.Progress(request->sha256());
    status = progress.status();
    if (progress.ok()) {
      response->set_sha256(request->sha256());
      response->set_received_bytes(static_cast<uint64_t>(progress->received_bytes));
      response->set_complete(progress->complete);
    }
  }
  reactor->Finish(ToGrpc(status));
  return reactor;
}

absl::StatusOr<v1::Job> MvbrdfService::JobMessage(const std::string& job_id) {
  absl::StatusOr<store::Job> job = jobs_.GetJob(job_id);
  if (!job.ok()) return job.status();
  absl::StatusOr<std::vector<store::Task>> tasks = jobs_.TasksOfJob(job_id);
  if (!tasks.ok()) return tasks.status();
  v1::Job message = ToProto(*job, *tasks);
  AttachReport(artifacts_, message);
  return message;
}

absl::Status MvbrdfService::Submit(const std::string& client, const v1::SubmitJobRequest& request, v1::Job* job) {
  const std::string& sha256 = request.bundle_sha256();
  if (absl::Status s = BundleArea::CheckDigest("bundle_sha256", sha256); !s.ok()) return s;
  const uint32_t atlas_size = request.options().atlas_size() == 0 ? 512 : request.options().atlas_size();
  if (atlas_size > static_cast<uint32_t>(limits_.max_atlas_size)) {
    return absl::ResourceExhaustedError(absl::StrCat("options.atlas_size: ", atlas_size,
                                                     " exceeds the server's limit ", limits_.max_atlas_size,
                                                     " (max_atlas_size)"));
  }
  absl::StatusOr<UploadProgress> progress = bundles_.Progress(sha256);
  if (!progress.ok()) return progress.status();
  if (!progress->complete) {
    return absl::FailedPreconditionError(absl::StrCat("bundle_sha256: bundle ", sha256, " is not uploaded (",
                                                      progress->received_bytes, " bytes received)"));
  }
  if (limits_.max_jobs_per_client > 0) {
    absl::StatusOr<std::vector<store::Job>> mine = jobs_.ListJobs(client);
    if (!mine.ok()) return mine.status();
    const auto active = std::count_if(mine->begin(), mine->end(),
                                      [](const store::Job& j) { return !store::IsFinal(j.state); });
    if (active >= limits_.max_jobs_per_client) {
      return absl::ResourceExhaustedError(absl::StrCat("client \"", client, "\" has ", active,
                                                       " unfinished jobs, the limit is ",
                                                       limits_.max_jobs_per_client));
    }
  }

  absl::StatusOr<std::filesystem::path> scene_file =
      bundles_.UnpackedScene(sha256, request.scene_path(), limits_.max_bundle_bytes);
  if (!scene_file.ok()) {
    // A bundle that hashes right but does not unpack is the caller's input.
    if (absl::IsDataLoss(scene_file.status())) return absl::InvalidArgumentError(scene_file.status().message());
    return scene_file.status();
  }
  // The frame limit first, from the scene file alone: a scene claiming
  // 10^6 frames is refused before any video is probed.
  if (absl::StatusOr<v1::Scene> message = scene::ReadScene(*scene_file);
      message.ok() && std::max<uint64_t>(message->frames().count(), message->frames().indices_size()) >
                          static_cast<uint64_t>(limits_.max_frames)) {
    return absl::ResourceExhaustedError(absl::StrCat("scene.frames.count: ",
                                                     std::max<uint64_t>(message->frames().count(),
                                                                        message->frames().indices_size()),
                                                     " frames exceed the server's limit ", limits_.max_frames,
                                                     " (max_frames)"));
  }
  scene::LoadOptions load;
  load.check_all_frames = false;
  load.probe_videos = true;
  absl::StatusOr<scene::Sequence> sequence = scene::LoadSequence(*scene_file, load);
  if (!sequence.ok()) {
    // The bundle's content is the caller's input, whatever the failure.
    return absl::InvalidArgumentError(sequence.status().message());
  }
  absl::StatusOr<JobPlan> plan = PlanJob(request, *sequence);
  if (!plan.ok()) return plan.status();

  const int64_t now_ms = clock_();
  absl::StatusOr<std::string> job_id = jobs_.CreateJob({client, sha256, request.SerializeAsString()}, now_ms);
  if (!job_id.ok()) return job_id.status();
  absl::Status built = AddJobTasks(jobs_, *job_id, *plan, now_ms).status();
  if (built.ok()) built = jobs_.SealJob(*job_id, now_ms);
  if (!built.ok()) {
    // Half a graph must never run.
    (void)jobs_.CancelJob(*job_id, now_ms);
    return built;
  }
  if (notify_work_) notify_work_();
  absl::StatusOr<v1::Job> message = JobMessage(*job_id);
  if (!message.ok()) return message.status();
  *job = *std::move(message);
  return absl::OkStatus();
}

grpc::ServerUnaryReactor* MvbrdfService::SubmitJob(grpc::CallbackServerContext* context,
                                                   const v1::SubmitJobRequest* request,
                                                   v1::SubmitJobResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  absl::StatusOr<auth::Principal> caller = Caller(*context);
  reactor->Finish(ToGrpc(caller.ok() ? Submit(caller->name, *request, response->mutable_job()) : caller.status()));
  return reactor;
}

grpc::ServerWriteReactor<v1::JobEvent>* MvbrdfService::WatchJob(grpc::CallbackServerContext* context,
                                                                const v1::WatchJobRequest* request) {
  absl::StatusOr<auth::Principal> caller = Caller(*context);
  absl::Status allowed = caller.ok() ? CheckJobAccess(*caller, request->job_id()) : caller.status();
  if (!allowed.ok()) {
    return new auth::FailedWriteReactor<v1::JobEvent>(allowed);
  }
  return watchers_.Watch(request->job_id());
}

grpc::ServerWriteReactor<v1::ArtifactChunk>* MvbrdfService::FetchArtifact(grpc::CallbackServerContext* context,
                                                                          const v1::FetchArtifactRequest* request) {
  absl::StatusOr<auth::Principal> caller = Caller(*context);
  absl::Status allowed = caller.ok() ? CheckJobAccess(*caller, request->job_id()) : caller.status();
  if (!allowed.ok()) {
    return new auth::FailedWriteReactor<v1::ArtifactChunk>(allowed);
  }
  const int64_t chunk_bytes = std::min(kArtifactChunkBytes, limits_.max_message_bytes - kChunkOverheadBytes);
  return new FetchReactor(artifacts_, *request, chunk_bytes);
}

absl::Status MvbrdfService::ListArtifactsOf(const std::string& job_id, v1::ListArtifactsResponse* response) {
  absl::StatusOr<store::Job> job = jobs_.GetJob(job_id);
  if (!job.ok()) return job.status();
  if (job->state != store::JobState::kSucceeded) {
    return absl::FailedPreconditionError(absl::StrCat(
        "job ", job_id, " is ", store::JobStateName(job->state),
        job->state == store::JobState::kQueued || job->state == store::JobState::kRunning
            ? ": its artifacts are listed once it has succeeded ('mvbrdf watch' follows it)"
            : ": it has no results"));
  }
  absl::StatusOr<std::vector<store::Artifact>> listed = artifacts_.ArtifactsOfJob(job_id);
  if (!listed.ok()) return listed.status();
  std::vector<store::Artifact> sorted = *std::move(listed);
  std::sort(sorted.begin(), sorted.end(),
            [](const store::Artifact& a, const store::Artifact& b) { return a.name < b.name; });
  for (const store::Artifact& a : sorted) {
    v1::ArtifactReady* ready = response->add_artifacts();
    ready->set_name(a.name);
    ready->set_sha256(a.sha256);
    ready->set_size(static_cast<uint64_t>(a.size));
  }
  return absl::OkStatus();
}

grpc::ServerUnaryReactor* MvbrdfService::ListArtifacts(grpc::CallbackServerContext* context,
                                                       const v1::ListArtifactsRequest* request,
                                                       v1::ListArtifactsResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  absl::StatusOr<auth::Principal> caller = Caller(*context);
  absl::Status status = caller.ok() ? CheckJobAccess(*caller, request->job_id()) : caller.status();
  if (status.ok()) status = ListArtifactsOf(request->job_id(), response);
  reactor->Finish(ToGrpc(status));
  return reactor;
}

grpc::ServerUnaryReactor* MvbrdfService::CancelJob(grpc::CallbackServerContext* context,
                                                   const v1::CancelJobRequest* request, v1::Job* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  absl::StatusOr<auth::Principal> caller = Caller(*context);
  absl::Status status = caller.ok() ? CheckJobAccess(*caller, request->job_id()) : caller.status();
  if (status.ok()) {
    status = jobs_.CancelJob(request->job_id(), clock_());
    // A job that already succeeded or failed keeps its state: the answer
    // says which (not an error: nothing is left to cancel).
    if (absl::IsFailedPrecondition(status)) {
      absl::StatusOr<store::Job> job = jobs_.GetJob(request->job_id());
      if (job.ok() && store::IsFinal(job->state)) status = absl::OkStatus();
    }
  }
  if (status.ok()) {
    absl::StatusOr<v1::Job> job = JobMessage(request->job_id());
    status = job.status();
    if (job.ok()) *response = *std::move(job);
  }
  reactor->Finish(ToGrpc(status));
  return reactor;
}

grpc::ServerUnaryReactor* MvbrdfService::ListJobs(grpc::CallbackServerContext* context,
                                                  const v1::ListJobsRequest* request, v1::ListJobsResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  const size_t limit = request->limit() == 0 ? 100 : request->limit();
  absl::StatusOr<auth::Principal> caller = Caller(*context);
  if (!caller.ok()) {
    reactor->Finish(ToGrpc(caller.status()));
    return reactor;
  }
  // An admin lists every client's jobs.
  absl::StatusOr<std::vector<store::Job>> jobs =
      caller->authenticated && caller->role == auth::Role::kAdmin ? jobs_.ListAllJobs() : jobs_.ListJobs(caller->name);
  absl::Status status = jobs.status();
  if (jobs.ok()) {
    // The newest `limit`, oldest first.
    const size_t first = jobs->size() > limit ? jobs->size() - limit : 0;
    for (size_t i = first; i < jobs->size() && status.ok(); ++i) {
      absl::StatusOr<std::vector<store::Task>> tasks = jobs_.TasksOfJob((*jobs)[i].id);
      status = tasks.status();
      if (!tasks.ok()) continue;
      v1::Job* job = response->add_jobs();
      *job = ToProto((*jobs)[i], *tasks);
      AttachReport(artifacts_, *job);
    }
  }
  reactor->Finish(ToGrpc(status));
  return reactor;
}

}  // namespace mvbrdf::clients_api
