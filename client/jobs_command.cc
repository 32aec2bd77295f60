// `mvbrdf jobs --server HOST:PORT [--json]`: the caller's jobs.
#include <cstdio>

#include <grpcpp/grpcpp.h>

#include "client/commands.h"
#include "client/connection.h"
#include "client/flags.h"
#include "client/job_state_name.h"
#include "client/stage_lines.h"
#include "core/base/proto_json.h"
#include "core/scene/names.h"
#include "mvbrdf/v1/service.grpc.pb.h"

namespace mvbrdf::client {

int RunJobs(const std::vector<std::string>& args) {
  std::string address, client_name = "anonymous";
  bool json = false;
  int limit = 100;
  FlagParser flags(
      "jobs", "Lists the caller's jobs on a server, newest last, with each task's worker (by --name) and run time.");
  flags.AddString("--server ADDR", &address, "the server, host:port (required)");
  flags.AddString("--client NAME", &client_name, "the client name jobs were submitted as (without tokens)");
  ConnectionFlags connection;
  AddConnectionFlags(flags, &connection);
  flags.AddInt("--limit N", &limit, "jobs to list, at most");
  flags.AddBool("--json", &json, "print the ListJobsResponse as JSON");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf jobs: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  if (absl::Status s = CheckLabel(client_name, "--client"); !s.ok()) {
    std::fprintf(stderr, "mvbrdf jobs: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (address.empty() || limit < 1) {
    std::fprintf(stderr, "mvbrdf jobs: %s\n", address.empty() ? "--server: required" : "--limit: must be >= 1");
    return kExitUsage;
  }
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel(address, connection);
  if (!channel.ok()) {
    std::fprintf(stderr, "mvbrdf jobs: %s\n", std::string(channel.status().message()).c_str());
    return kExitUsage;
  }
  auto stub = v1::Mvbrdf::NewStub(*channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  context.AddMetadata("x-mvbrdf-client", client_name);
  v1::ListJobsRequest request;
  request.set_limit(static_cast<uint32_t>(limit));
  v1::ListJobsResponse response;
  const grpc::Status status = stub->ListJobs(&context, request, &response);
  if (!status.ok()) {
    std::fprintf(stderr, "mvbrdf jobs: error: %s: %s\n", address.c_str(), status.error_message().c_str());
    return ExitCodeForRpc(status.error_code());
  }
  if (json) {
    std::printf("%s\n", MessageToJson(response).c_str());
    return kExitOk;
  }
  if (response.jobs_size() == 0) std::printf("no jobs\n");
  for (const v1::Job& job : response.jobs()) {
    std::printf("%s  %-9s  %d tasks%s%s\n", job.id().c_str(), JobStateName(job.state()), job.tasks_size(),
                job.error().empty() ? "" : "  ", job.error().c_str());
    for (const v1::TaskInfo& t : job.tasks()) {
      // The worker by its --name; its id (first 8 digits) as a detail.
      std::string worker = t.worker().empty() ? "-" : WorkerShown(t.worker_name(), t.worker());
      if (!t.worker_name().empty() && !t.worker().empty()) worker += " (" + t.worker().substr(0, 8) + ")";
      std::printf("    %-12s %-28s %-9s %-24s %6.1f s%s\n", t.kind().c_str(), scene::ShownName(t.key()).c_str(),
                  t.state().c_str(), worker.c_str(), t.seconds(), t.samples_from_cache() ? "  (cache)" : "");
    }
  }
  return kExitOk;
}

}  // namespace mvbrdf::client
