#include "client/embedded_service.h"

#include <algorithm>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"
#include "server/clients_api/bundle_area.h"

namespace mvbrdf::client {

namespace fs = std::filesystem;

std::shared_ptr<grpc::Channel> ServiceChannel(const std::string& address) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(16 << 20);
  return grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
}

absl::StatusOr<std::unique_ptr<EmbeddedService>> EmbeddedService::Start(const EmbeddedOptions& options) {
  if (options.workers < 0 || options.workers > 64) {
    return absl::InvalidArgumentError(absl::StrCat("workers: must be in [0, 64], got ", options.workers));
  }
  auto service = std::unique_ptr<EmbeddedService>(new EmbeddedService());
  service->options_ = options;
  server::ServerOptions so = options.server;
  so.listen_address = "127.0.0.1:0";
  so.data_dir = options.data_dir;
  MVBRDF_ASSIGN_OR_RETURN(service->server_, server::Server::Start(so));
  service->channel_ = ServiceChannel(service->server_->address());
  for (int i = 0; i < options.workers; ++i) service->AddWorker();
  return service;
}

void EmbeddedService::AddWorker() {
  const int i = static_cast<int>(workers_.size());
  worker::WorkerOptions wo;
  wo.channel = channel_;
  wo.name = absl::StrCat("in-process-", i);
  wo.cache_dir = options_.data_dir / absl::StrCat("worker-", i);
  // The server's unpacked copies (it validates every job's bundle that way).
  wo.server_unpacked_bundles = clients_api::BundleArea(options_.data_dir).ScenesDir();
  wo.egl = options_.egl;
  wo.threads = options_.threads_per_worker;
  wo.wait_seconds = 2;
  // One worker runs the job's reflectance after its gather: one pass.
  wo.gather_texel_statistics = options_.workers == 1;
  wo.report_html = false;  // `run --report` writes DIR/report.html itself
  if (options_.log) {
    wo.log = [log = options_.log, name = wo.name](const std::string& line) { log(absl::StrCat("worker ", name, ": ", line)); };
  }
  workers_.push_back(std::make_unique<worker::Worker>(wo));
  worker::Worker* w = workers_.back().get();
  auto log = options_.log;
  threads_.emplace_back([w, log, name = wo.name] {
    const absl::Status ran = w->Run();
    if (!ran.ok() && log) log(absl::StrCat("worker ", name, " stopped: ", ran.message()));
  });
}

absl::Status EmbeddedService::AdoptBundle(const fs::path& archive, const std::string& sha256) {
  MVBRDF_RETURN_IF_ERROR(clients_api::BundleArea::CheckDigest("sha256", sha256));
  const fs::path target = clients_api::BundleArea(options_.data_dir).BundlePath(sha256);
  std::error_code ec;
  if (fs::is_regular_file(target, ec)) {  // uploaded before: the same bytes
    fs::remove(archive, ec);
    return absl::OkStatus();
  }
  fs::create_directories(target.parent_path(), ec);
  if (!ec) fs::rename(archive, target, ec);
  if (ec) return absl::UnavailableError(absl::StrCat(archive.string(), " -> ", target.string(), ": ", ec.message()));
  return absl::OkStatus();
}

EmbeddedService::~EmbeddedService() {
  for (auto& w : workers_) w->Stop();
  for (std::thread& t : threads_) t.join();
  if (server_ != nullptr) server_->Shutdown(2.0);
}

absl::StatusOr<std::vector<std::string>> EmbeddedService::CopyArtifacts(const std::string& job_id,
                                                                        const fs::path& out_dir) {
  MVBRDF_ASSIGN_OR_RETURN(const std::vector<store::Artifact> artifacts,
                          server_->artifacts().ArtifactsOfJob(job_id));
  // result.json last: a directory with it holds a whole run (an interrupted
  // copy leaves none, run removes the previous one first).
  std::vector<store::Artifact> ordered = artifacts;
  std::stable_partition(ordered.begin(), ordered.end(),
                        [](const store::Artifact& a) { return a.name != "result.json"; });
  std::vector<std::string> names;
  for (const store::Artifact& a : ordered) {
    const fs::path name(a.name);
    bool parent = false;
    for (const fs::path& part : name) parent = parent || part == "..";
    if (a.name.empty() || name.has_root_path() || parent) {
      return absl::InvalidArgumentError(absl::StrCat("artifact \"", a.name, "\": not a relative path inside the output"));
    }
    MVBRDF_ASSIGN_OR_RETURN(const fs::path source, server_->artifacts().OpenVerified(a.sha256));
    // Through a temporary renamed into place: copy_file left a truncated
    // kd.exr on a full disk and said "Input/output error".
    MVBRDF_RETURN_IF_ERROR(CopyFileReplacing(source, out_dir / a.name));
    names.push_back(a.name);
  }
  return names;
}

}  // namespace mvbrdf::client
