// `mvbrdf submit SCENE --server HOST:PORT [...]`: packs the scene's bundle,
// uploads what the server does not have yet (resuming a partial upload) and
// queues a job; with --watch follows it like `mvbrdf watch`.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "client/bundle_upload.h"
#include "client/commands.h"
#include "client/connection.h"
#include "client/flags.h"
#include "client/job_flags.h"
#include "client/progress.h"
#include "core/base/files.h"
#include "core/base/proto_json.h"
#include "core/bundle/bundle.h"
#include "core/scene/names.h"
#include "mvbrdf/v1/service.grpc.pb.h"

namespace mvbrdf::client {
namespace {

// Removes the temporary bundle on every path out of RunSubmit.
class TempFile {
 public:
  explicit TempFile(std::filesystem::path path) : path_(std::move(path)) {}
  ~TempFile() {
    std::error_code ignored;
    std::filesystem::remove(path_, ignored);
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

int LocalFailure(const absl::Status& status) { return ReportFailure(status, "mvbrdf submit"); }

int RpcFailure(const std::string& what, const std::string& address, const grpc::Status& status) {
  std::fprintf(stderr, "mvbrdf submit: error: %s %s: %s\n", what.c_str(), scene::ShownName(address).c_str(),
               scene::ShownName(status.error_message()).c_str());
  return ExitCodeForRpc(status.error_code());
}

std::chrono::system_clock::time_point Deadline() {
  return std::chrono::system_clock::now() + std::chrono::seconds(30);
}

}  // namespace

int RunSubmit(const std::vector<std::string>& args) {
  std::string scene, address, client_name = "anonymous";
  JobFlags job;
  bool json = false, watch = false;
  FlagParser flags("submit",
                   "Packs SCENE and the files it names into a bundle, uploads the bytes the server does not have "
                   "yet, queues a job and prints its id. With --watch, then follows the job like 'mvbrdf watch' "
                   "(exit code 0 succeeded, 5 failed, 6 cancelled).");
  flags.AddPositional("SCENE", &scene, true, "the scene file (scene.json)");
  flags.AddString("--server ADDR", &address, "the server, host:port (required)");
  flags.AddString("--client NAME", &client_name, "the client name the job is submitted as (without tokens)");
  ConnectionFlags connection;
  AddConnectionFlags(flags, &connection);
  AddJobFlags(flags, &job);
  flags.AddBool("--watch", &watch, "follow the job's events until it ends");
  flags.AddBool("--json", &json, "print the SubmitJobResponse as JSON (and with --watch each event as a JSON line)");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf submit: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  if (absl::Status s = CheckLabel(client_name, "--client"); !s.ok()) {
    std::fprintf(stderr, "mvbrdf submit: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (address.empty()) {
    std::fprintf(stderr, "mvbrdf submit: --server: required\n");
    return kExitUsage;
  }
  v1::SubmitJobRequest submit;
  if (absl::Status s = ToSubmitRequest(job, &submit); !s.ok()) {
    std::fprintf(stderr, "mvbrdf submit: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  submit.set_scene_path(std::filesystem::path(scene).filename().string());

  // The bundle, in a private temporary file.
  const absl::StatusOr<std::filesystem::path> tmp_dir = TemporaryDirectory();
  if (!tmp_dir.ok()) return LocalFailure(tmp_dir.status());
  std::random_device random;
  const TempFile archive(*tmp_dir / ("mvbrdf-submit-" + std::to_string(getpid()) + "-" +
                                    std::to_string(random()) + ".tar"));
  absl::StatusOr<bundle::BundleInfo> info = bundle::PackBundle(scene, archive.path());
  if (!info.ok()) return LocalFailure(info.status());
  submit.set_bundle_sha256(info->sha256);

  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel(address, connection);
  if (!channel.ok()) {
    std::fprintf(stderr, "mvbrdf submit: %s\n", std::string(channel.status().message()).c_str());
    return kExitUsage;
  }
  auto stub = v1::Mvbrdf::NewStub(*channel);
  {
    ProgressPrinter progress(stderr);
    UploadOutcome outcome;
    const absl::Status uploaded = UploadBundleFile(*stub, client_name, archive.path(), info->sha256,
                                                   static_cast<uint64_t>(info->size), &progress, &outcome);
    if (!uploaded.ok()) {
      std::fprintf(stderr, "mvbrdf submit: error: %s to %s\n", std::string(uploaded.message()).c_str(),
                   address.c_str());
      return ExitCodeForRpc(static_cast<int>(uploaded.code()));
    }
    if (outcome.already_there) {
      std::fprintf(stderr, "bundle already on the server (%s, %llu bytes)\n", info->sha256.c_str(),
                   static_cast<unsigned long long>(info->size));
    } else if (outcome.resumed_at > 0) {
      std::fprintf(stderr, "resumed the upload at %llu of %llu bytes\n",
                   static_cast<unsigned long long>(outcome.resumed_at), static_cast<unsigned long long>(info->size));
    }
  }

  v1::SubmitJobResponse response;
  {
    grpc::ClientContext context;
    context.set_deadline(Deadline());
    context.AddMetadata("x-mvbrdf-client", client_name);
    const grpc::Status status = stub->SubmitJob(&context, submit, &response);
    if (!status.ok()) return RpcFailure("submit to", address, status);
  }
  if (json) {
    std::printf("%s\n", MessageToJson(response).c_str());
  } else {
    std::printf("%s\n", response.job().id().c_str());
  }
  std::fflush(stdout);
  if (!watch) return kExitOk;
  return WatchJobEvents("submit", *channel, client_name, response.job().id(), json);
}

}  // namespace mvbrdf::client
