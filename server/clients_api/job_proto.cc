#include "server/clients_api/job_proto.h"

#include <string>

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
  info.set_attempts(static_cast<uint32_t>(task.attempts));
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

grpc::Status ToGrpc(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()), std::string(status.message()));
}

}  // namespace mvbrdf::clients_api
