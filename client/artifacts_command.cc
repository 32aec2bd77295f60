// `mvbrdf artifacts JOB --server HOST:PORT [--json]`: the outputs of a
// succeeded job that `fetch` can download, with their sizes and digests.
#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstdio>

#include "client/commands.h"
#include "client/connection.h"
#include "client/flags.h"
#include "core/base/proto_json.h"
#include "core/scene/names.h"
#include "mvbrdf/v1/service.grpc.pb.h"

namespace mvbrdf::client {

grpc::Status ListJobArtifacts(const std::shared_ptr<grpc::Channel>& channel, const std::string& client_name,
                              const std::string& job_id, v1::ListArtifactsResponse* response) {
  auto stub = v1::Mvbrdf::NewStub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  context.AddMetadata("x-mvbrdf-client", client_name);
  v1::ListArtifactsRequest request;
  request.set_job_id(job_id);
  return stub->ListArtifacts(&context, request, response);
}

int RunArtifacts(const std::vector<std::string>& args) {
  std::string job_id, address, client_name = "anonymous";
  bool json = false;
  FlagParser flags("artifacts",
                   "Lists the outputs of a succeeded job that 'mvbrdf fetch' downloads (result.json, report.html, "
                   "atlases/..., atlas/...): name, size in bytes and SHA-256, in name order. Exit code 3 when there "
                   "is no such job or it has not succeeded (queued or running: no results yet; failed or "
                   "cancelled: none), 4 when the server is unreachable.");
  flags.AddPositional("JOB", &job_id, true, "the job id");
  flags.AddString("--server ADDR", &address, "the server, host:port (required)");
  flags.AddString("--client NAME", &client_name, "the client name sent to the server (without tokens)");
  ConnectionFlags connection;
  AddConnectionFlags(flags, &connection);
  flags.AddBool("--json", &json, "print the ListArtifactsResponse as JSON");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf artifacts: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  if (absl::Status s = CheckLabel(client_name, "--client"); !s.ok()) {
    std::fprintf(stderr, "mvbrdf artifacts: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (address.empty()) {
    std::fprintf(stderr, "mvbrdf artifacts: --server: required\n");
    return kExitUsage;
  }
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel(address, connection);
  if (!channel.ok()) {
    std::fprintf(stderr, "mvbrdf artifacts: %s\n", std::string(channel.status().message()).c_str());
    return kExitUsage;
  }
  v1::ListArtifactsResponse response;
  const grpc::Status status = ListJobArtifacts(*channel, client_name, job_id, &response);
  if (!status.ok()) {
    std::fprintf(stderr, "mvbrdf artifacts: error: %s: %s\n", scene::ShownName(job_id).c_str(),
                 scene::ShownName(status.error_message()).c_str());
    return ExitCodeForRpc(status.error_code());
  }
  if (json) {
    std::printf("%s\n", MessageToJson(response).c_str());
    return kExitOk;
  }
  for (const v1::ArtifactReady& a : response.artifacts()) {
    std::printf("%-40s %12llu  %s\n", scene::ShownName(a.name()).c_str(), static_cast<unsigned long long>(a.size()),
                a.sha256().c_str());
  }
  return kExitOk;
}

}  // namespace mvbrdf::client
