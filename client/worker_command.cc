// `mvbrdf worker --server HOST:PORT`: an EGL-headless worker. Registers with
// the server, leases tasks and runs them on its own EGL context until SIGINT
// or SIGTERM (the task in hand is finished first).
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <thread>

#include <grpcpp/grpcpp.h>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/connection.h"
#include "client/flags.h"
#include "worker/worker.h"

namespace mvbrdf::client {
namespace {

volatile std::sig_atomic_t g_stop = 0;
void OnSignal(int) { g_stop = 1; }

std::string DefaultCacheDir() {
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg != nullptr && *xdg != '\0') {
    return std::string(xdg) + "/mvbrdf/worker";
  }
  if (const char* home = std::getenv("HOME"); home != nullptr && *home != '\0') {
    return std::string(home) + "/.cache/mvbrdf/worker";
  }
  return "mvbrdf-worker-cache";
}

std::string DefaultName() {
  char host[256] = {0};
  gethostname(host, sizeof(host) - 1);
  return absl::StrCat(host, "-", getpid());
}

}  // namespace

int RunWorker(const std::vector<std::string>& args) {
  std::string address, egl = "auto";
  worker::WorkerOptions o;
  o.name = DefaultName();
  std::string cache_dir = DefaultCacheDir();
  FlagParser flags("worker",
                   "Runs an EGL-headless worker: registers with the server, leases tasks (resampling, light\n"
                   "sweep configurations, reflectance), runs them on its own EGL context and streams progress,\n"
                   "metrics, Samples and atlases back. Sequence bundles are downloaded once into --cache.\n"
                   "SIGINT/SIGTERM stop it after the task in hand.");
  flags.AddString("--server ADDR", &address, "the server's address, HOST:PORT (required)");
  flags.AddString("--name NAME", &o.name, "name shown in jobs/watch (default: host-pid)");
  ConnectionFlags connection;
  AddConnectionFlags(flags, &connection);
  flags.AddString("--cache DIR", &cache_dir, "bundle cache and scratch directory");
  flags.AddString("--egl PLATFORM", &egl, "EGL platform: auto, surfaceless (Mesa) or device (GPU)");
  flags.AddInt("--threads N", &o.threads, "threads for fitting");
  flags.AddInt("--wait SECONDS", &o.wait_seconds, "long-poll seconds per lease request");
  flags.AddInt("--max-tasks N", &o.max_tasks, "exit after this many tasks (0: run until stopped)");
  flags.AddBool("--gather-texels", &o.gather_texel_statistics,
                "keep a job's texel statistics from its gather for its reflectance (a lone worker: one pass, not two)");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf worker: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  absl::Status usage = absl::OkStatus();
  auto platform = gl::ParseEglPlatform(egl);
  if (!platform.ok()) usage = platform.status();
  if (usage.ok()) usage = CheckLabel(o.name, "--name");
  if (usage.ok() && address.empty()) usage = absl::InvalidArgumentError("--server: required (HOST:PORT)");
  if (usage.ok() && (o.threads < 1 || o.threads > 64)) usage = absl::InvalidArgumentError("--threads: must be in [1, 64]");
  if (usage.ok() && (o.wait_seconds < 1 || o.wait_seconds > 600)) {
    usage = absl::InvalidArgumentError("--wait: must be in [1, 600]");
  }
  if (usage.ok() && o.max_tasks < 0) usage = absl::InvalidArgumentError("--max-tasks: must be >= 0");
  if (!usage.ok()) {
    std::fprintf(stderr, "mvbrdf worker: %s\n", std::string(usage.message()).c_str());
    return kExitUsage;
  }
  o.egl = *platform;
  o.cache_dir = cache_dir;
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel(address, connection);
  if (!channel.ok()) {
    std::fprintf(stderr, "mvbrdf worker: %s\n", std::string(channel.status().message()).c_str());
    return kExitUsage;
  }
  o.channel = *channel;
  o.log = [name = o.name](const std::string& line) {
    std::fprintf(stderr, "worker %s: %s\n", name.c_str(), line.c_str());
  };
  worker::Worker w(o);
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  std::thread watcher([&w] {
    while (!g_stop) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    w.Stop();
  });
  const absl::Status ran = w.Run();
  g_stop = 1;
  watcher.join();
  if (!ran.ok()) return ReportFailure(ran, "mvbrdf worker");
  std::fprintf(stderr, "worker %s: stopped after %d tasks\n", o.name.c_str(), w.tasks_run());
  return kExitOk;
}

}  // namespace mvbrdf::client
