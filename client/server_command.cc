// `mvbrdf server --data DIR [--listen HOST:PORT]`: the job server.
#include <csignal>
#include <cstdio>
#include <thread>

#include "client/commands.h"
#include "client/flags.h"
#include "server/process/server.h"

namespace mvbrdf::client {
namespace {

volatile std::sig_atomic_t g_stop = 0;
void OnSignal(int) { g_stop = 1; }

}  // namespace

int RunServer(const std::vector<std::string>& args) {
  server::ServerOptions o;
  std::string data_dir;
  int max_bundle_mib = static_cast<int>(o.limits.max_bundle_bytes >> 20);
  int max_jobs = static_cast<int>(o.limits.max_jobs_per_client);
  int lease_seconds = static_cast<int>(o.workers.lease_seconds);
  FlagParser flags("server",
                   "Runs the mvbrdf job server: clients upload sequence bundles and submit jobs, workers lease\n"
                   "their tasks. State (SQLite database, bundles, artifacts) lives in --data and survives restarts.\n"
                   "Prints 'listening on HOST:PORT' once ready; stops cleanly on SIGINT/SIGTERM.");
  flags.AddString("--listen", &o.listen_address, "address to listen on, host:port (port 0: any free port)");
  flags.AddString("--data", &data_dir, "the server's state directory (required)");
  flags.AddInt("--max-bundle-mib", &max_bundle_mib, "largest accepted bundle, MiB");
  flags.AddInt("--max-jobs-per-client", &max_jobs, "unfinished jobs per client, at most (0: no limit)");
  flags.AddInt("--lease-seconds", &lease_seconds, "how long a worker's task lease lasts without renewal");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf server: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  o.data_dir = data_dir;
  o.limits.max_bundle_bytes = static_cast<int64_t>(max_bundle_mib) << 20;
  o.limits.max_jobs_per_client = max_jobs;
  o.workers.lease_seconds = lease_seconds;
  if (absl::Status s = o.Check(); !s.ok()) {
    std::fprintf(stderr, "mvbrdf server: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  auto server = server::Server::Start(o);
  if (!server.ok()) return ReportFailure(server.status());
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  std::printf("listening on %s (data in %s)\n", (*server)->address().c_str(), data_dir.c_str());
  std::fflush(stdout);
  while (!g_stop) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::printf("shutting down\n");
  (*server)->Shutdown();
  return kExitOk;
}

}  // namespace mvbrdf::client
