// The service in one process: a server on a loopback port and N workers on
// threads (each with its own EGL context), over real gRPC channels. `mvbrdf
// run` uses it as the embedded default, and integration tests use it as the
// in-process server with real workers.
#ifndef MVBRDF_CLIENT_EMBEDDED_SERVICE_H_
#define MVBRDF_CLIENT_EMBEDDED_SERVICE_H_

#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/gl/egl_context.h"
#include "mvbrdf/v1/service.grpc.pb.h"
#include "server/process/server.h"
#include "worker/worker.h"

namespace mvbrdf::client {

struct EmbeddedOptions {
  std::filesystem::path data_dir;  // the server's state; workers cache under it
  int workers = 1;
  gl::EglPlatform egl = gl::EglPlatform::kAuto;
  int threads_per_worker = 2;
  // Worker log lines ("worker in-process-0: ..."); may be empty.
  std::function<void(const std::string&)> log;
  // Server settings beyond the data directory and address.
  server::ServerOptions server;
};

class EmbeddedService {
 public:
  static absl::StatusOr<std::unique_ptr<EmbeddedService>> Start(const EmbeddedOptions& options);
  // Stops the workers (after their task in hand) and the server.
  ~EmbeddedService();

  const std::string& address() const { return server_->address(); }
  std::shared_ptr<grpc::Channel> channel() const { return channel_; }
  server::Server& server() { return *server_; }
  const std::vector<std::unique_ptr<worker::Worker>>& workers() const { return workers_; }
  // Adds one more worker thread (e.g. to make a sweep parallel midway).
  void AddWorker();

  // Hands the bundle file `archive` (PackBundle's, hashing to `sha256`) to
  // the server by renaming it into its bundle area, as a complete upload
  // would have left it, without copying or hashing it again (issue #17:
  // bench-e2e's bundle is 518 MB). The file is gone afterwards. An error
  // (e.g. `archive` on another file system) leaves it in place: upload it.
  absl::Status AdoptBundle(const std::filesystem::path& archive, const std::string& sha256);

  // Copies the artifacts of job `job_id` from the artifact store to
  // out_dir/<name>, each verified against its SHA-256; returns their names.
  absl::StatusOr<std::vector<std::string>> CopyArtifacts(const std::string& job_id,
                                                         const std::filesystem::path& out_dir);

 private:
  EmbeddedService() = default;
  EmbeddedOptions options_;
  std::unique_ptr<server::Server> server_;
  std::shared_ptr<grpc::Channel> channel_;
  std::vector<std::unique_ptr<worker::Worker>> workers_;
  std::vector<std::thread> threads_;
};

// A channel to `address` that accepts the service's largest messages.
std::shared_ptr<grpc::Channel> ServiceChannel(const std::string& address);

}  // namespace mvbrdf::client

#endif  // MVBRDF_CLIENT_EMBEDDED_SERVICE_H_
