// Store rows -> API messages, for the answers of SubmitJob, CancelJob,
// ListJobs and the events of WatchJob.
#ifndef MVBRDF_SERVER_CLIENTS_API_JOB_PROTO_H_
#define MVBRDF_SERVER_CLIENTS_API_JOB_PROTO_H_

#include <vector>

#include "grpcpp/support/status.h"
#include "absl/status/status.h"
#include "mvbrdf/v1/service.pb.h"
#include "server/store/job_store.h"

namespace mvbrdf::clients_api {

v1::JobState ToProto(store::JobState state);
// TaskInfo.seconds stays 0: the store does not record when a lease began.
v1::TaskInfo ToProto(const store::Task& task);
v1::Job ToProto(const store::Job& job, const std::vector<store::Task>& tasks);

// The same code and message (absl and gRPC share the canonical codes).
grpc::Status ToGrpc(const absl::Status& status);

}  // namespace mvbrdf::clients_api

#endif  // MVBRDF_SERVER_CLIENTS_API_JOB_PROTO_H_
