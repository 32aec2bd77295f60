// The mvbrdf server process: one SQLite database and data directory, the two
// gRPC services over them (Mvbrdf for clients, Workers for workers), standard
// health checking and reflection, on an address from the flags (never
// hard-coded; port 0 lets the OS choose, for tests).
//
// Threading: Start() and Shutdown() from one thread; the services run on
// gRPC's callback threads and their own poller threads.
#ifndef MVBRDF_SERVER_PROCESS_SERVER_H_
#define MVBRDF_SERVER_PROCESS_SERVER_H_

#include <filesystem>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
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

  absl::Status Check() const;
};

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
  std::unique_ptr<store::JobStore> jobs_;
  std::unique_ptr<store::ArtifactStore> artifacts_;
  std::unique_ptr<store::SampleCache> sample_cache_;
  std::unique_ptr<clients_api::BundleArea> bundles_;  // paths only (FetchBundle)
  std::unique_ptr<WorkersService> workers_;
  std::unique_ptr<clients_api::MvbrdfService> clients_;
  std::unique_ptr<grpc::Server> grpc_server_;
  std::string address_;
};

}  // namespace mvbrdf::server

#endif  // MVBRDF_SERVER_PROCESS_SERVER_H_
