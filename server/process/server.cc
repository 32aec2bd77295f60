#include "server/process/server.h"

#include <netdb.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"

namespace mvbrdf::server {
namespace {

int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Whether `address` (host:port, or a unix socket) is reachable only from
// this machine.
bool IsLoopback(const std::string& address) {
  if (absl::StartsWith(address, "unix:") || absl::StartsWith(address, "unix-abstract:")) return true;
  std::string host = address.substr(0, address.rfind(':'));
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  return host == "localhost" || host == "::1" || absl::StartsWith(host, "127.");
}

absl::StatusOr<std::string> ReadPem(const std::filesystem::path& path, absl::string_view flag) {
  absl::StatusOr<std::string> text = ReadFileToString(path);
  if (!text.ok()) return absl::NotFoundError(absl::StrCat(flag, ": ", path.string(), ": cannot read"));
  if (text->find("-----BEGIN ") == std::string::npos) {
    return absl::InvalidArgumentError(absl::StrCat(flag, ": ", path.string(), ": not a PEM file"));
  }
  return text;
}

// The listening port's credentials: TLS when a certificate is configured.
absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> ListenCredentials(const ServerOptions& options) {
  if (options.tls_cert_file.empty()) return grpc::InsecureServerCredentials();
  MVBRDF_ASSIGN_OR_RETURN(std::string cert, ReadPem(options.tls_cert_file, "--tls-cert"));
  MVBRDF_ASSIGN_OR_RETURN(std::string key, ReadPem(options.tls_key_file, "--tls-key"));
  grpc::SslServerCredentialsOptions ssl(GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE);
  if (!options.tls_client_ca_file.empty()) {
    MVBRDF_ASSIGN_OR_RETURN(ssl.pem_root_certs, ReadPem(options.tls_client_ca_file, "--tls-client-ca"));
    ssl.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
  }
  ssl.pem_key_cert_pairs.push_back({std::move(key), std::move(cert)});
  return grpc::SslServerCredentials(ssl);
}

// Why `address` (host:port, already checked) cannot be listened on, as far
// as a plain bind(2) of the same address can tell: "address already in use
// (...)" or the errno text; empty when the bind works (then gRPC failed for
// another reason, e.g. TLS).
std::string WhyNotListenable(const std::string& address) {
  const size_t colon = address.rfind(':');
  if (colon == std::string::npos || absl::StartsWith(address, "unix")) return "";
  std::string host = address.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[') host = host.substr(1, host.size() - 2);
  const std::string port = address.substr(colon + 1);
  addrinfo hints{};
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  if (const int rc = getaddrinfo(host.c_str(), port.c_str(), &hints, &found); rc != 0) {
    return absl::StrCat("cannot resolve \"", host, "\": ", gai_strerror(rc));
  }
  std::string why;
  for (addrinfo* a = found; a != nullptr; a = a->ai_next) {
    const int fd = socket(a->ai_family, a->ai_socktype, a->ai_protocol);
    if (fd < 0) continue;
    const int one = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));  // as gRPC does; not SO_REUSEPORT
    if (bind(fd, a->ai_addr, a->ai_addrlen) != 0) {
      why = errno == EADDRINUSE ? "the address is already in use (is another server listening on it?)"
                                : std::strerror(errno);
    }
    close(fd);
    if (!why.empty()) break;
  }
  freeaddrinfo(found);
  return why;
}

// Why the unix socket `path` cannot be listened on: another process accepts
// on it (gRPC unlinks an existing socket file and binds anew, so a second
// server took the first one's clients and, exiting, removed the socket
// file), or it is no socket. Empty when it can: no file, or a stale socket.
std::string WhyNotUnixListenable(const std::string& path) {
  struct stat st {};
  if (lstat(path.c_str(), &st) != 0) return errno == ENOENT ? "" : std::strerror(errno);
  if (!S_ISSOCK(st.st_mode)) return absl::StrCat(path, " exists and is not a socket");
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof(addr.sun_path)) {
    return absl::StrCat("the socket path is longer than ", sizeof(addr.sun_path) - 1, " bytes");
  }
  std::memcpy(addr.sun_path, path.data(), path.size());
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return std::strerror(errno);
  const bool accepted = connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) == 0;
  close(fd);
  return accepted ? absl::StrCat("another process is listening on ", path, " (is another server using it?)") : "";
}

}  // namespace

absl::Status CheckListenAddress(const std::string& address, absl::string_view origin) {
  const auto bad = [&](absl::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat(origin, ": ", what, ", got \"", absl::CHexEscape(address), "\""));
  };
  if (absl::StartsWith(address, "unix:") || absl::StartsWith(address, "unix-abstract:")) {
    if (address.back() == ':') return bad("expected a socket path after the scheme");
    return absl::OkStatus();
  }
  const size_t colon = address.rfind(':');
  if (colon == std::string::npos) return bad("expected host:port (port 0 picks a free one)");
  const std::string host = address.substr(0, colon), port = address.substr(colon + 1);
  if (host.empty()) return bad("expected host:port with a host (e.g. 127.0.0.1, 0.0.0.0 or [::1])");
  if (host.front() == '[') {
    if (host.size() < 3 || host.back() != ']') return bad("expected [IPv6 address]:port");
    for (char c : host.substr(1, host.size() - 2)) {
      if (!absl::ascii_isxdigit(c) && c != ':' && c != '.' && c != '%' && !absl::ascii_isalnum(c)) {
        return bad("expected [IPv6 address]:port");
      }
    }
  } else {
    for (char c : host) {
      if (c == ':') return bad("an IPv6 address needs brackets ([::1]:port)");
      if (!absl::ascii_isalnum(c) && c != '.' && c != '-' && c != '_') {
        return bad("expected host:port, the host a name or an IP address");
      }
    }
  }
  if (port.empty() || port.size() > 5 || !std::all_of(port.begin(), port.end(), absl::ascii_isdigit) ||
      std::stoi(port) > 65535) {
    return bad("the port must be a number in 0..65535 (0 picks a free one)");
  }
  return absl::OkStatus();
}

absl::Status ServerOptions::Check() const {
  MVBRDF_RETURN_IF_ERROR(CheckListenAddress(listen_address, "--listen"));
  if (data_dir.empty()) return absl::InvalidArgumentError("--data: required (the server's state directory)");
  if (tls_cert_file.empty() != tls_key_file.empty()) {
    return absl::InvalidArgumentError("--tls-cert, --tls-key: give both (TLS) or neither (plaintext)");
  }
  if (!tls_client_ca_file.empty() && tls_cert_file.empty()) {
    return absl::InvalidArgumentError("--tls-client-ca: needs --tls-cert and --tls-key (mutual TLS is TLS)");
  }
  if (tokens_file.empty() && !allow_unauthenticated && !IsLoopback(listen_address)) {
    return absl::FailedPreconditionError(absl::StrCat(
        "--listen: ", listen_address,
        " is reachable from other machines, but no --tokens-file is configured: give one (docs/service.md "
        "\"Security\"), listen on 127.0.0.1, or pass --allow-unauthenticated"));
  }
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
  if (!options.tokens_file.empty()) {
    absl::StatusOr<auth::TokenTable> tokens = auth::TokenTable::ReadFile(options.tokens_file);
    if (!tokens.ok()) return absl::Status(tokens.status().code(), absl::StrCat("--tokens-file: ", tokens.status().message()));
    s->tokens_ = std::make_shared<const auth::TokenTable>(*std::move(tokens));
  }
  MVBRDF_ASSIGN_OR_RETURN(std::shared_ptr<grpc::ServerCredentials> credentials, ListenCredentials(options));
  s->tls_ = !options.tls_cert_file.empty();
  WorkersServiceOptions workers_options = options.workers;
  workers_options.tokens = s->tokens_;
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
      [self](absl::string_view sha256) { return self->bundles_->BundlePath(sha256); }, NowMs, workers_options,
      [self](const v1::JobEvent& event) {
        if (self->clients_ != nullptr) self->clients_->PushEvent(event);
      });
  s->clients_ = std::make_unique<clients_api::MvbrdfService>(*s->jobs_, *s->artifacts_, options.data_dir, NowMs,
                                                             options.limits,
                                                             [self] { self->workers_->NotifyWork(); }, s->tokens_);
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  // gRPC sets SO_REUSEPORT by default on Linux: a second server on a port
  // another one holds would start and take half of its clients' calls.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  const bool unix_socket = absl::StartsWith(options.listen_address, "unix:");
  if (unix_socket) {
    if (const std::string why = WhyNotUnixListenable(options.listen_address.substr(5)); !why.empty()) {
      return absl::UnavailableError(absl::StrCat("--listen: cannot listen on ", options.listen_address, ": ", why));
    }
  }
  int port = 0;
  builder.AddListeningPort(options.listen_address, credentials, &port);
  builder.SetMaxReceiveMessageSize(static_cast<int>(options.limits.max_message_bytes) + (1 << 16));
  builder.SetMaxSendMessageSize(static_cast<int>(options.limits.max_message_bytes) + (1 << 16));
  builder.RegisterService(s->clients_.get());
  builder.RegisterService(s->workers_.get());
  s->grpc_server_ = builder.BuildAndStart();
  if (s->grpc_server_ == nullptr || port == 0) {
    std::string why = WhyNotListenable(options.listen_address);
    if (why.empty() && s->tls_) why = "with TLS: do --tls-cert and --tls-key match?";
    return absl::UnavailableError(
        absl::StrCat("--listen: cannot listen on ", options.listen_address, why.empty() ? "" : ": ", why));
  }
  const std::string host = options.listen_address.substr(0, options.listen_address.rfind(':'));
  // A unix socket has no port (gRPC reports 1): its address is the one given.
  s->address_ = unix_socket || absl::StartsWith(options.listen_address, "unix-abstract:")
                    ? options.listen_address
                    : absl::StrCat(host, ":", port);
  s->data_dir_ = options.data_dir;
  s->health_thread_ = std::thread([self] { self->WatchDataDir(); });
  return s;
}

void Server::WatchDataDir() {
  grpc::HealthCheckServiceInterface* health = grpc_server_->GetHealthCheckService();
  bool serving = true;
  std::unique_lock<std::mutex> lock(health_mu_);
  while (!health_cv_.wait_for(lock, std::chrono::milliseconds(500), [this] { return stopping_; })) {
    // access(2) sees a deleted directory, a deleted (still open) database
    // and a read-only file system, for root too.
    const bool usable =
        access(data_dir_.c_str(), W_OK | X_OK) == 0 && access((data_dir_ / "state.db").c_str(), R_OK | W_OK) == 0;
    if (usable != serving && health != nullptr) {
      serving = usable;
      health->SetServingStatus(serving);
    }
  }
}

void Server::Wait() { grpc_server_->Wait(); }

void Server::Shutdown(double grace_seconds) {
  if (health_thread_.joinable()) {
    {
      std::lock_guard<std::mutex> lock(health_mu_);
      stopping_ = true;
    }
    health_cv_.notify_all();
    health_thread_.join();
  }
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
