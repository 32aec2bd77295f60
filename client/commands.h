// The `mvbrdf` subcommands. Each takes the arguments after its name and
// returns the process exit code (see ExitCode).
#ifndef MVBRDF_CLIENT_COMMANDS_H_
#define MVBRDF_CLIENT_COMMANDS_H_

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"

namespace grpc {
class Channel;
class Status;
}  // namespace grpc

namespace mvbrdf::v1 {
class ListArtifactsResponse;
}  // namespace mvbrdf::v1

namespace mvbrdf::scene {
struct Sequence;
}  // namespace mvbrdf::scene

namespace mvbrdf::client {

// Exit codes scripts can rely on.
enum ExitCode : int {
  kExitOk = 0,
  kExitInternal = 1,      // a bug or an unexpected failure
  kExitUsage = 2,         // bad command line
  kExitInvalidInput = 3,  // the scene or its files are not valid
  kExitEnvironment = 4,   // EGL/GL, codecs, the file system or memory are not usable (a full or read-only
                          // disk, an atlas too large for memory); the server is unreachable or at its limits
  kExitJobFailed = 5,     // `watch` (and `submit --watch`): the job failed (its reason is printed)
  kExitJobCancelled = 6,  // `watch` (and `submit --watch`): the job was cancelled
  // Service commands: a job that does not exist (or is another client's) is 3, as is `artifacts` of a job that
  // has not succeeded and `fetch` of a name the job does not have; `cancel` of a job that already succeeded or
  // failed is 0 ("job ID already succeeded; nothing to cancel": its state is kept).
  kExitDenied = 7,  // the server refused the credentials (no, unknown or wrong-role token)
};

// The exit code of a failed Status (kExitInvalidInput, kExitEnvironment,
// kExitDenied for UNAUTHENTICATED, or kExitInternal).
int ExitCodeFor(const absl::Status& status);
// Prints "<command>: error: <reason>" on stderr and returns ExitCodeFor(status).
int ReportFailure(const absl::Status& status, const std::string& command = "mvbrdf");

int RunSynth(const std::vector<std::string>& args);
int RunValidate(const std::vector<std::string>& args);
int RunResample(const std::vector<std::string>& args);
int RunRun(const std::vector<std::string>& args);
int RunEvaluate(const std::vector<std::string>& args);
int RunRender(const std::vector<std::string>& args);
int RunExport(const std::vector<std::string>& args);
// `export` and `run --export FILE`: INVALID_ARGUMENT (a usage error) unless
// `out` names a .glb or .gltf file; then the run in `run_dir` written there
// (frame -1: the rest pose; animation: core/export/gltf_export.h), its
// summary and warnings printed.
absl::Status CheckExportFile(const std::string& flag, const std::string& out);
absl::Status ExportRun(const std::filesystem::path& run_dir, const scene::Sequence& sequence, const std::string& out,
                       int frame, bool animation = false);
int RunServer(const std::vector<std::string>& args);
int RunWorker(const std::vector<std::string>& args);
int RunJobs(const std::vector<std::string>& args);
int RunSubmit(const std::vector<std::string>& args);
int RunWatch(const std::vector<std::string>& args);
int RunFetch(const std::vector<std::string>& args);
int RunCancel(const std::vector<std::string>& args);
int RunArtifacts(const std::vector<std::string>& args);
int RunHealth(const std::vector<std::string>& args);
int RunReport(const std::vector<std::string>& args);
int RunImport(const std::vector<std::string>& args);
// `mvbrdf --version`; VersionText() is its output (version_command.cc).
int RunVersion(const std::vector<std::string>& args);
std::string VersionText();

class FlagParser;
// What `mvbrdf report` and `mvbrdf run --report` take (report_command.cc).
struct ReportFlags {
  std::string truth;
  bool no_truth = false;
  std::string tradeoff;
  int relit_frames = 12;
  bool no_render = false;
  std::string egl = "auto";
  std::string scene;  // `report --scene`: the run's scene file (default: result.json's)
};
void AddReportFlags(FlagParser& parser, ReportFlags* flags);
// Writes the HTML report of the run in `run_dir` to `out`.
absl::Status WriteRunReport(const std::filesystem::path& run_dir, const std::filesystem::path& out,
                            const ReportFlags& flags);

// The exit code of a failed RPC, from its grpc::StatusCode (as an int):
// kExitInvalidInput for INVALID_ARGUMENT, NOT_FOUND and FAILED_PRECONDITION,
// kExitEnvironment for UNAVAILABLE, DEADLINE_EXCEEDED and RESOURCE_EXHAUSTED
// (the server's disk is full, or a server limit), kExitDenied for
// UNAUTHENTICATED and PERMISSION_DENIED, else kExitInternal
// (report_failure.cc).
int ExitCodeForRpc(int grpc_code);

// Follows job `job_id` on `channel` until its event stream ends, printing each
// event (one JSON object per line when `json`); errors are prefixed with
// "mvbrdf <command>:". Returns kExitOk, kExitJobFailed, kExitJobCancelled or
// an RPC failure's code (watch_command.cc; also `submit --watch`).
int WatchJobEvents(const std::string& command, const std::shared_ptr<grpc::Channel>& channel,
                   const std::string& client_name, const std::string& job_id, bool json);

// ListArtifacts of job `job_id` (artifacts_command.cc; also `fetch --all`).
grpc::Status ListJobArtifacts(const std::shared_ptr<grpc::Channel>& channel, const std::string& client_name,
                              const std::string& job_id, v1::ListArtifactsResponse* response);

}  // namespace mvbrdf::client

#endif  // MVBRDF_CLIENT_COMMANDS_H_
