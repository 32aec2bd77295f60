#include "server/clients_api/job_proto.h"

#include <string>

#include "absl/strings/str_cat.h"
#include "core/base/proto_json.h"

namespace mvbrdf::clients_api {

v1::JobState ToProto(store::JobState state) {
  switch (state) {
    case store::JobState::kQueued: return v1::QUEUED;
    case store::JobState::kRunning: return v1::RUNNING;
    case store::JobState::kSucceeded: return v1::SUCCEEDED;
    case store::JobState::kFailed: return v1::FAILED;
    case store::JobState::kCancelled: return v1::CANCELLED;
  }
  return v1::JOB_STATE_UNSPECIFIED;
}

v1::TaskInfo ToProto(const store::Task& task) {
  v1::TaskInfo info;
  info.set_id(task.id);
  info.set_kind(task.kind);
  info.set_key(task.key);
  info.set_state(std::string(store::TaskStateName(task.state)));
  info.set_worker(task.lease_owner);
  info.set_worker_name(task.worker_name);
  info.set_attempts(static_cast<uint32_t>(task.attempts));
  const bool finished = task.state == store::TaskState::kDone || task.state == store::TaskState::kFailed;
  if (finished && task.started_ms > 0 && task.updated_ms >= task.started_ms) {
    info.set_seconds(static_cast<double>(task.updated_ms - task.started_ms) / 1000.0);
  }
  info.set_samples_from_cache(task.samples_from_cache);
  info.set_last_error(task.error);
  info.set_worker_faults(static_cast<uint32_t>(task.worker_faults));
  return info;
}

v1::Job ToProto(const store::Job& job, const std::vector<store::Task>& tasks) {
  v1::Job out;
  out.set_id(job.id);
  out.set_client(job.client);
  out.set_state(ToProto(job.state));
  out.set_bundle_sha256(job.scene_hash);
  out.set_created_unix_ms(job.created_ms);
  out.set_updated_unix_ms(job.updated_ms);
  out.set_error(job.error);
  for (const store::Task& task : tasks) *out.add_tasks() = ToProto(task);
  return out;
}

void AttachReport(store::ArtifactStore& artifacts, v1::Job& job) {
  if (job.state() != v1::SUCCEEDED) return;
  absl::StatusOr<std::vector<store::Artifact>> listed = artifacts.ArtifactsOfJob(job.id());
  if (!listed.ok()) return;
  for (const store::Artifact& artifact : *listed) {
    if (artifact.name != kReportArtifact) continue;
    absl::StatusOr<std::string> json = artifacts.Read(artifact.sha256);
    if (!json.ok()) return;
    v1::RunReport report;
    if (JsonToMessage(*json, absl::StrCat("job ", job.id(), ": ", kReportArtifact), &report).ok()) {
      *job.mutable_report() = std::move(report);
    }
    return;
  }
}

grpc::Status ToGrpc(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()), std::string(status.message()));
}

}  // namespace mvbrdf::clients_api
