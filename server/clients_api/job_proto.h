// Store rows -> API messages, for the answers of SubmitJob, CancelJob,
// ListJobs and the events of WatchJob.
#ifndef MVBRDF_SERVER_CLIENTS_API_JOB_PROTO_H_
#define MVBRDF_SERVER_CLIENTS_API_JOB_PROTO_H_

#include <vector>

#include "grpcpp/support/status.h"
#include "absl/status/status.h"
#include "mvbrdf/v1/service.pb.h"
#include "server/store/artifact_store.h"
#include "server/store/job_store.h"

namespace mvbrdf::clients_api {

v1::JobState ToProto(store::JobState state);
// TaskInfo.seconds: from the start of the last lease to the end, for done
// and failed tasks (0 while running, and for tasks leased before schema
// version 3 recorded lease starts).
v1::TaskInfo ToProto(const store::Task& task);
v1::Job ToProto(const store::Job& job, const std::vector<store::Task>& tasks);

// The artifact whose JSON is a succeeded job's Job.report.
inline constexpr char kReportArtifact[] = "result.json";

// Sets job.report from the job's "result.json" artifact when the job
// SUCCEEDED (one small verified file read). A job without one, or whose
// report does not read or parse, keeps no report: listing jobs must not fail
// because of one damaged artifact (fetching it reports the damage).
void AttachReport(store::ArtifactStore& artifacts, v1::Job& job);

// The same code and message (absl and gRPC share the canonical codes).
grpc::Status ToGrpc(const absl::Status& status);

}  // namespace mvbrdf::clients_api

#endif  // MVBRDF_SERVER_CLIENTS_API_JOB_PROTO_H_
