// `mvbrdf watch JOB --server HOST:PORT [--json]`: a job's events until its
// stream ends (the server ends it after a final state).
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "client/commands.h"
#include "client/connection.h"
#include "client/flags.h"
#include "client/job_state_name.h"
#include "core/base/proto_json.h"
#include "client/stage_lines.h"
#include "core/scene/names.h"
#include "mvbrdf/v1/service.grpc.pb.h"

namespace mvbrdf::client {
namespace {

// One JSON object on one line (MessageToJson adds line breaks).
std::string OneLineJson(const google::protobuf::Message& message) { return MessageToOneLineJson(message); }

// Plain lines, with progress updated in place on a terminal.
class EventPrinter {
 public:
  explicit EventPrinter(std::FILE* out) : out_(out), tty_(isatty(fileno(out)) != 0) {}

  void Print(const v1::JobEvent& event) {
    switch (event.event_case()) {
      case v1::JobEvent::kState:
        Line("state: " + std::string(JobStateName(event.state())));
        break;
      case v1::JobEvent::kStageStarted:
        Line(StageStartedLine(event.stage_started()));
        break;
      case v1::JobEvent::kProgress: {
        const v1::Progress& p = event.progress();
        char text[256];
        if (p.eta_seconds() >= 0) {
          std::snprintf(text, sizeof text, "%-16s %5.1f%%  about %.0f s left", p.stage().c_str(),
                        100.0 * p.fraction(), p.eta_seconds());
        } else {
          std::snprintf(text, sizeof text, "%-16s %5.1f%%", p.stage().c_str(), 100.0 * p.fraction());
        }
        if (tty_) {
          std::fprintf(out_, "\r\033[K%s", text);
          std::fflush(out_);
          in_place_ = true;
        } else {
          Line(text);
        }
        break;
      }
      case v1::JobEvent::kStageFinished:
        // One line per finished task: stage, key, worker, time, metrics.
        for (const std::string& line : StageFinishedLines(event.stage_finished())) Line(line);
        break;
      case v1::JobEvent::kArtifact: {
        const v1::ArtifactReady& a = event.artifact();
        Line("artifact " + a.name() + "  " + std::to_string(a.size()) + " bytes  sha256 " + a.sha256());
        break;
      }
      case v1::JobEvent::kFailed:
        Line("failed: " + event.failed());
        break;
      default:
        break;
    }
  }

  // Ends an in-place progress line.
  void Finish() {
    if (in_place_) std::fputs("\n", out_);
    in_place_ = false;
    std::fflush(out_);
  }

 private:
  void Line(const std::string& text) {
    std::fprintf(out_, in_place_ ? "\r\033[K%s\n" : "%s\n", text.c_str());
    std::fflush(out_);
    in_place_ = false;
  }

  std::FILE* out_;
  bool tty_;
  bool in_place_ = false;
};

}  // namespace

int WatchJobEvents(const std::string& command, const std::shared_ptr<grpc::Channel>& channel,
                   const std::string& client_name, const std::string& job_id, bool json) {
  auto stub = v1::Mvbrdf::NewStub(channel);
  grpc::ClientContext context;  // no deadline: a job may run for hours
  context.AddMetadata("x-mvbrdf-client", client_name);
  v1::WatchJobRequest request;
  request.set_job_id(job_id);
  std::unique_ptr<grpc::ClientReader<v1::JobEvent>> reader = stub->WatchJob(&context, request);
  EventPrinter printer(stdout);
  v1::JobState last_state = v1::JOB_STATE_UNSPECIFIED;
  std::string reason;
  v1::JobEvent event;
  while (reader->Read(&event)) {
    if (json) {
      std::printf("%s\n", OneLineJson(event).c_str());
      std::fflush(stdout);
    } else {
      printer.Print(event);
    }
    if (event.event_case() == v1::JobEvent::kState) last_state = event.state();
    if (event.event_case() == v1::JobEvent::kFailed) reason = event.failed();
  }
  if (!json) printer.Finish();
  const grpc::Status status = reader->Finish();
  if (!status.ok()) {
    std::fprintf(stderr, "mvbrdf %s: error: %s: %s\n", command.c_str(), scene::ShownName(job_id).c_str(),
                 scene::ShownName(status.error_message()).c_str());
    return ExitCodeForRpc(status.error_code());
  }
  switch (last_state) {
    case v1::SUCCEEDED:
      return kExitOk;
    case v1::FAILED:
      std::fprintf(stderr, "mvbrdf %s: job %s failed: %s\n", command.c_str(), scene::ShownName(job_id).c_str(),
                   reason.empty() ? "(no reason given)" : scene::ShownName(reason).c_str());
      return kExitJobFailed;
    case v1::CANCELLED:
      if (json) std::fprintf(stderr, "mvbrdf %s: job %s was cancelled\n", command.c_str(), job_id.c_str());
      return kExitJobCancelled;
    default:
      std::fprintf(stderr, "mvbrdf %s: error: the event stream of job %s ended before a final state (last: %s)\n",
                   command.c_str(), job_id.c_str(), JobStateName(last_state));
      return kExitInternal;
  }
}

int RunWatch(const std::vector<std::string>& args) {
  std::string job_id, address, client_name = "anonymous";
  bool json = false;
  FlagParser flags("watch",
                   "Follows a job's events (state changes, each stage started and finished with its configuration, "
                   "its worker's --name, its run time and metrics, progress, artifacts) until the job ends. Exit code: "
                   "0 the job succeeded, 5 it failed (the reason is printed), 6 it was cancelled; 3 no such job, 4 the "
                   "server is unreachable.");
  flags.AddPositional("JOB", &job_id, true, "the job id (from 'mvbrdf submit' or 'mvbrdf jobs')");
  flags.AddString("--server ADDR", &address, "the server, host:port (required)");
  flags.AddString("--client NAME", &client_name, "the client name sent to the server (without tokens)");
  ConnectionFlags connection;
  AddConnectionFlags(flags, &connection);
  flags.AddBool("--json", &json, "print each JobEvent as one JSON object per line");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf watch: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  if (absl::Status s = CheckLabel(client_name, "--client"); !s.ok()) {
    std::fprintf(stderr, "mvbrdf watch: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (address.empty()) {
    std::fprintf(stderr, "mvbrdf watch: --server: required\n");
    return kExitUsage;
  }
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel(address, connection);
  if (!channel.ok()) {
    std::fprintf(stderr, "mvbrdf watch: %s\n", std::string(channel.status().message()).c_str());
    return kExitUsage;
  }
  return WatchJobEvents("watch", *channel, client_name, job_id, json);
}

}  // namespace mvbrdf::client
