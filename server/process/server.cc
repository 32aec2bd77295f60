#include "server/process/server.h"

#include <chrono>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"

namespace mvbrdf::server {
namespace {

int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

absl::Status ServerOptions::Check() const {
  if (listen_address.empty() || listen_address.find(':') == std::string::npos) {
    return absl::InvalidArgumentError(
        absl::StrCat("--listen: expected host:port (port 0 picks a free one), got \"", listen_address, "\""));
  }
  if (data_dir.empty()) return absl::InvalidArgumentError("--data: required (the server's state directory)");
  MVBRDF_RETURN_IF_ERROR(limits.Check());
  MVBRDF_RETURN_IF_ERROR(sample_cache.Check());
  return workers.Check();
}

absl::StatusOr<std::unique_ptr<Server>> Server::Start(const ServerOptions& options) {
  MVBRDF_RETURN_IF_ERROR(options.Check());
  std::error_code ec;
  std::filesystem::create_directories(options.data_dir, ec);
  if (ec) {
    return absl::PermissionDeniedError(
        absl::StrCat(options.data_dir.string(), ": cannot create the data directory: ", ec.message()));
  }
  std::unique_ptr<Server> s(new Server());
  const std::filesystem::path db = options.data_dir / "state.db";
  MVBRDF_ASSIGN_OR_RETURN(s->jobs_, store::JobStore::Open(db));
  MVBRDF_ASSIGN_OR_RETURN(s->artifacts_, store::ArtifactStore::Open(db, options.data_dir / "artifacts"));
  MVBRDF_ASSIGN_OR_RETURN(s->sample_cache_, store::SampleCache::Open(db, options.sample_cache));
  // The same layout the clients service uploads into.
  s->bundles_ = std::make_unique<clients_api::BundleArea>(options.data_dir);
  // Progress the workers report goes to the clients watching the job.
  Server* self = s.get();
  s->workers_ = std::make_unique<WorkersService>(
      *s->jobs_, *s->artifacts_, *s->sample_cache_,
      [self](absl::string_view sha256) { return self->bundles_->BundlePath(sha256); }, NowMs, options.workers,
      [self](const v1::JobEvent& event) {
        if (self->clients_ != nullptr) self->clients_->PushEvent(event);
      });
  s->clients_ = std::make_unique<clients_api::MvbrdfService>(*s->jobs_, *s->artifacts_, options.data_dir, NowMs,
                                                             options.limits,
                                                             [self] { self->workers_->NotifyWork(); });
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort(options.listen_address, grpc::InsecureServerCredentials(), &port);
  builder.SetMaxReceiveMessageSize(static_cast<int>(options.limits.max_message_bytes) + (1 << 16));
  builder.SetMaxSendMessageSize(static_cast<int>(options.limits.max_message_bytes) + (1 << 16));
  builder.RegisterService(s->clients_.get());
  builder.RegisterService(s->workers_.get());
  s->grpc_server_ = builder.BuildAndStart();
  if (s->grpc_server_ == nullptr || port == 0) {
    return absl::UnavailableError(absl::StrCat("--listen: cannot listen on ", options.listen_address));
  }
  const std::string host = options.listen_address.substr(0, options.listen_address.rfind(':'));
  s->address_ = absl::StrCat(host, ":", port);
  return s;
}

void Server::Wait() { grpc_server_->Wait(); }

void Server::Shutdown(double grace_seconds) {
  if (grpc_server_ == nullptr) return;
  workers_->Stop();
  grpc_server_->Shutdown(std::chrono::system_clock::now() +
                         std::chrono::milliseconds(static_cast<int64_t>(grace_seconds * 1000.0)));
}

Server::~Server() {
  Shutdown(0.0);
  if (grpc_server_ != nullptr) grpc_server_->Wait();
}

}  // namespace mvbrdf::server
