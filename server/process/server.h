// The mvbrdf server process: one SQLite database and data directory, the two
// gRPC services over them (Mvbrdf for clients, Workers for workers), standard
// health checking and reflection, on an address from the flags (never
// hard-coded; port 0 lets the OS choose, for tests).
//
// Security (docs/service.md "Security"): with a tokens file every call of
// the two services needs a bearer token of the right role
// (server/auth/authorize.h); health checking and reflection stay open for
// probes. With a certificate and key the port speaks only TLS (and with a
// client CA only mutual TLS). Without tokens the server refuses a
// non-loopback listen address unless allow_unauthenticated is set.
//
// Threading: Start() and Shutdown() from one thread; the services run on
// gRPC's callback threads and their own poller threads.
#ifndef MVBRDF_SERVER_PROCESS_SERVER_H_
#define MVBRDF_SERVER_PROCESS_SERVER_H_

#include <condition_variable>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "absl/status/statusor.h"
#include "server/auth/token_table.h"
#include "server/clients_api/mvbrdf_service.h"
#include "server/store/artifact_store.h"
#include "server/store/job_store.h"
#include "server/store/sample_cache.h"
#include "server/workers_api/workers_service.h"

namespace mvbrdf::server {

struct ServerOptions {
  std::string listen_address = "127.0.0.1:0";  // host:port
  std::filesystem::path data_dir;              // required: state.db, bundles/, artifacts/
  clients_api::ServiceLimits limits;
  WorkersServiceOptions workers;
  // The Sample cache in state.db (triangle Samples per bundle and options).
  store::SampleCacheOptions sample_cache;

  // Bearer tokens (server/auth/token_table.h); empty: authentication off.
  std::filesystem::path tokens_file;
  // TLS: the server's certificate chain and private key (PEM), both or
  // neither; empty: plaintext.
  std::filesystem::path tls_cert_file;
  std::filesystem::path tls_key_file;
  // With TLS: clients must present a certificate signed by this CA (PEM).
  std::filesystem::path tls_client_ca_file;
  // Listen on a non-loopback address without tokens (refused otherwise).
  bool allow_unauthenticated = false;

  absl::Status Check() const;
};

// Checks a listen address: "host:port" (a name, an IPv4 address or a
// bracketed IPv6 address; port a decimal number in 0..65535, 0 picking a free
// one) or "unix:PATH" / "unix-abstract:NAME". INVALID_ARGUMENT naming
// `origin` (the flag or config field) otherwise; gRPC itself would wrap a
// port above 65535 (":99999" listens on 34463).
absl::Status CheckListenAddress(const std::string& address, absl::string_view origin);

class Server {
 public:
  // Opens the stores (creating the data directory and migrating the
  // database) and starts listening.
  static absl::StatusOr<std::unique_ptr<Server>> Start(const ServerOptions& options);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // The bound address (with the port the OS chose for port 0).
  const std::string& address() const { return address_; }
  // Whether calls need tokens, and whether the port speaks TLS.
  bool authenticating() const { return tokens_ != nullptr; }
  bool tls() const { return tls_; }
  // Blocks until Shutdown() is called from another thread.
  void Wait();
  // Answers parked long polls, stops accepting calls and waits up to
  // `grace_seconds` for calls in flight.
  void Shutdown(double grace_seconds = 5.0);

  // For in-process embedding (`mvbrdf run` starts a Server and reads its
  // artifacts directly): the stores and services, alive as long as the
  // Server. Any thread (the stores and services are thread-safe).
  store::JobStore& jobs() { return *jobs_; }
  store::ArtifactStore& artifacts() { return *artifacts_; }
  store::SampleCache& sample_cache() { return *sample_cache_; }
  WorkersService& workers() { return *workers_; }
  clients_api::MvbrdfService& clients() { return *clients_; }

 private:
  Server() = default;
  std::shared_ptr<const auth::TokenTable> tokens_;  // null: authentication off
  bool tls_ = false;
  std::unique_ptr<store::JobStore> jobs_;
  std::unique_ptr<store::ArtifactStore> artifacts_;
  std::unique_ptr<store::SampleCache> sample_cache_;
  std::unique_ptr<clients_api::BundleArea> bundles_;  // paths only (FetchBundle)
  std::unique_ptr<WorkersService> workers_;
  std::unique_ptr<clients_api::MvbrdfService> clients_;
  std::unique_ptr<grpc::Server> grpc_server_;
  std::string address_;
  // Sets the health service to NOT_SERVING while the data directory or
  // state.db is gone or not writable (and back to SERVING once it is).
  std::filesystem::path data_dir_;
  std::mutex health_mu_;
  std::condition_variable health_cv_;
  bool stopping_ = false;  // guarded by health_mu_
  std::thread health_thread_;
  void WatchDataDir();
};

}  // namespace mvbrdf::server

#endif  // MVBRDF_SERVER_PROCESS_SERVER_H_
