// `mvbrdf cancel JOB --server HOST:PORT [--json]`: cancels a job and prints
// its state.
#include <chrono>
#include <cstdio>

#include <grpcpp/grpcpp.h>

#include "client/commands.h"
#include "client/connection.h"
#include "client/flags.h"
#include "client/job_state_name.h"
#include "core/base/proto_json.h"
#include "core/scene/names.h"
#include "mvbrdf/v1/service.grpc.pb.h"

namespace mvbrdf::client {

int RunCancel(const std::vector<std::string>& args) {
  std::string job_id, address, client_name = "anonymous";
  bool json = false;
  FlagParser flags("cancel",
                   "Cancels a job (its unfinished tasks are not run) and prints the job's state. A job that already "
                   "succeeded or failed keeps its state: cancel says so and exits 0 (nothing to cancel). Exit code "
                   "3 when there is no such job, 4 when the server is unreachable.");
  flags.AddPositional("JOB", &job_id, true, "the job id");
  flags.AddString("--server ADDR", &address, "the server, host:port (required)");
  flags.AddString("--client NAME", &client_name, "the client name sent to the server (without tokens)");
  ConnectionFlags connection;
  AddConnectionFlags(flags, &connection);
  flags.AddBool("--json", &json, "print the Job as JSON");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf cancel: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  if (absl::Status s = CheckLabel(client_name, "--client"); !s.ok()) {
    std::fprintf(stderr, "mvbrdf cancel: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (address.empty()) {
    std::fprintf(stderr, "mvbrdf cancel: --server: required\n");
    return kExitUsage;
  }
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel(address, connection);
  if (!channel.ok()) {
    std::fprintf(stderr, "mvbrdf cancel: %s\n", std::string(channel.status().message()).c_str());
    return kExitUsage;
  }
  auto stub = v1::Mvbrdf::NewStub(*channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  context.AddMetadata("x-mvbrdf-client", client_name);
  v1::CancelJobRequest request;
  request.set_job_id(job_id);
  v1::Job job;
  const grpc::Status status = stub->CancelJob(&context, request, &job);
  if (!status.ok()) {
    std::fprintf(stderr, "mvbrdf cancel: error: %s: %s\n", scene::ShownName(job_id).c_str(),
                 scene::ShownName(status.error_message()).c_str());
    return ExitCodeForRpc(status.error_code());
  }
  if (json) {
    std::printf("%s\n", MessageToJson(job).c_str());
    return kExitOk;
  }
  if (job.state() == v1::SUCCEEDED || job.state() == v1::FAILED) {
    std::printf("job %s already %s; nothing to cancel\n", job.id().c_str(), JobStateName(job.state()));
    return kExitOk;
  }
  std::printf("%s  %s\n", job.id().c_str(), JobStateName(job.state()));
  return kExitOk;
}

}  // namespace mvbrdf::client
