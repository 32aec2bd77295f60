// The client-facing gRPC service `mvbrdf.v1.Mvbrdf` (issue #5,
// docs/service.md): upload a sequence bundle (chunked, resumable,
// content-addressed), submit a job (validated at once, then queued as a task
// graph), watch it, fetch its artifacts, cancel it, list one's jobs.
//
// Callback API: unary calls answer on gRPC's thread; UploadBundle,
// WatchJob and FetchArtifact are reactors.
//
// Who calls (server/auth/authorize.h): with tokens, every method needs a
// client or admin token; the token's name is the client, which owns the jobs
// it submits. A client sees, watches, fetches and cancels only its own jobs
// (another client's job is NOT_FOUND, the same answer as a job that does not
// exist, so job ids cannot be probed); an admin sees every job. Bundles are
// content-addressed and shared: whoever knows a bundle's SHA-256 may query
// it and submit jobs on it. Without tokens (authentication off) the client is
// the "x-mvbrdf-client" metadata ("anonymous" without it), a label that
// scopes ListJobs and the per-client job limit, not a credential.
//
// Ownership: the stores outlive the service; the service outlives the
// grpc::Server it is registered with (shut the server down first).
#ifndef MVBRDF_SERVER_CLIENTS_API_MVBRDF_SERVICE_H_
#define MVBRDF_SERVER_CLIENTS_API_MVBRDF_SERVICE_H_

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "mvbrdf/v1/service.grpc.pb.h"
#include "server/auth/token_table.h"
#include "server/clients_api/bundle_area.h"
#include "server/clients_api/job_watchers.h"
#include "server/store/artifact_store.h"
#include "server/store/job_store.h"

namespace mvbrdf::clients_api {

struct ServiceLimits {
  // Largest bundle accepted (UploadChunk.total_size; also the most bytes a
  // bundle may unpack to).
  int64_t max_bundle_bytes = int64_t{8} << 30;
  // Jobs one client may have that are not final yet (0: no limit).
  int max_jobs_per_client = 16;
  // The server's largest message (set the same on the ServerBuilder): upload
  // chunks with more data are refused, artifact chunks stay below it.
  int64_t max_message_bytes = int64_t{4} << 20;
  // How often WatchJob reads the store for changes.
  int watch_poll_ms = 200;
  // Largest atlas a job may ask for (options.atlas_size; 0 there means
  // 512), texels per side: an atlas of n² texels costs ~100 bytes per texel
  // in the reflectance pass. RESOURCE_EXHAUSTED above it.
  int max_atlas_size = 4096;
  // Most frames a job's sequence may have. RESOURCE_EXHAUSTED above it.
  int max_frames = 100000;

  absl::Status Check() const;
};

class MvbrdfService final : public v1::Mvbrdf::CallbackService {
 public:
  // `data_dir`: bundles/, uploads/ and scenes/ live under it. `clock`: now in
  // unix ms. `notify_work`: called after a job's tasks were added (wakes
  // long-polling workers); may be empty. `tokens`: null turns
  // authentication off.
  MvbrdfService(store::JobStore& jobs, store::ArtifactStore& artifacts, std::filesystem::path data_dir,
                std::function<int64_t()> clock, ServiceLimits limits, std::function<void()> notify_work = {},
                std::shared_ptr<const auth::TokenTable> tokens = nullptr);

  // Forwards a progress event (stage started, progress, stage finished with
  // metrics, artifact ready) to the current watchers of event.job_id. Any
  // thread.
  void PushEvent(const v1::JobEvent& event) { watchers_.Push(event); }
  size_t ActiveWatches() const { return watchers_.ActiveWatches(); }

  grpc::ServerReadReactor<v1::UploadChunk>* UploadBundle(grpc::CallbackServerContext* context,
                                                         v1::UploadStatus* response) override;
  grpc::ServerUnaryReactor* QueryUpload(grpc::CallbackServerContext* context, const v1::QueryUploadRequest* request,
                                        v1::UploadStatus* response) override;
  grpc::ServerUnaryReactor* SubmitJob(grpc::CallbackServerContext* context, const v1::SubmitJobRequest* request,
                                      v1::SubmitJobResponse* response) override;
  grpc::ServerWriteReactor<v1::JobEvent>* WatchJob(grpc::CallbackServerContext* context,
                                                   const v1::WatchJobRequest* request) override;
  grpc::ServerWriteReactor<v1::ArtifactChunk>* FetchArtifact(grpc::CallbackServerContext* context,
                                                             const v1::FetchArtifactRequest* request) override;
  // Every artifact of a succeeded job, by name. NOT_FOUND for an unknown
  // (or another client's) job; FAILED_PRECONDITION naming the state for a
  // job that has not succeeded (it has no results to list yet, or none).
  grpc::ServerUnaryReactor* ListArtifacts(grpc::CallbackServerContext* context, const v1::ListArtifactsRequest* request,
                                          v1::ListArtifactsResponse* response) override;
  // Cancels a queued or running job. A job already succeeded or failed keeps
  // its state and is answered as it is (OK; Job.state says which).
  grpc::ServerUnaryReactor* CancelJob(grpc::CallbackServerContext* context, const v1::CancelJobRequest* request,
                                      v1::Job* response) override;
  grpc::ServerUnaryReactor* ListJobs(grpc::CallbackServerContext* context, const v1::ListJobsRequest* request,
                                     v1::ListJobsResponse* response) override;

 private:
  absl::Status Submit(const std::string& client, const v1::SubmitJobRequest& request, v1::Job* job);
  absl::StatusOr<v1::Job> JobMessage(const std::string& job_id);
  absl::Status ListArtifactsOf(const std::string& job_id, v1::ListArtifactsResponse* response);
  // Authorize with a client token (see the top of this file).
  absl::StatusOr<auth::Principal> Caller(const grpc::CallbackServerContext& context) const;
  // OK when `caller` may act on job `job_id` (always without tokens or for
  // an admin); NOT_FOUND as for a missing job otherwise.
  absl::Status CheckJobAccess(const auth::Principal& caller, const std::string& job_id);

  store::JobStore& jobs_;
  store::ArtifactStore& artifacts_;
  const std::function<int64_t()> clock_;
  const ServiceLimits limits_;
  const std::function<void()> notify_work_;
  const std::shared_ptr<const auth::TokenTable> tokens_;
  BundleArea bundles_;
  JobWatchers watchers_;
};

}  // namespace mvbrdf::clients_api

#endif  // MVBRDF_SERVER_CLIENTS_API_MVBRDF_SERVICE_H_
