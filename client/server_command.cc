// `mvbrdf server [--config FILE] [--data DIR] [--listen HOST:PORT] ...`: the
// job server. Settings come from built-in defaults, then the config file
// (proto/mvbrdf/v1/server_config.proto as JSON), then the flags.
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/match.h"
#include "client/commands.h"
#include "client/flags.h"
#include "server/process/server.h"
#include "server/process/server_config.h"

namespace mvbrdf::client {
namespace {

volatile std::sig_atomic_t g_stop = 0;
void OnSignal(int) { g_stop = 1; }

// The value of --config in `args` (empty when absent): the file is read
// before the flags are parsed, so that the flags' defaults are its values.
std::string ConfigPathIn(const std::vector<std::string>& args) {
  std::string path;
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--config" && i + 1 < args.size()) {
      path = args[i + 1];
    } else if (absl::StartsWith(args[i], "--config=")) {
      path = args[i].substr(9);
    }
  }
  return path;
}

int UsageError(const absl::Status& status) {
  std::fprintf(stderr, "mvbrdf server: %s\n", std::string(status.message()).c_str());
  return kExitUsage;
}

}  // namespace

int RunServer(const std::vector<std::string>& args) {
  server::ServerOptions o;
  std::string config_path = ConfigPathIn(args);
  if (!config_path.empty()) {
    if (absl::Status s = server::LoadServerConfig(config_path, o); !s.ok()) return UsageError(s);
  }

  // Each flag starts at the value the file (or the default) gave; a flag
  // whose value changed overrides it, through the same checks as the file.
  std::string listen = o.listen_address;
  std::string data_dir = o.data_dir.string();
  int lease_seconds = o.workers.lease_seconds;
  int max_wait_seconds = o.workers.max_wait_seconds;
  int poll_interval_ms = o.workers.poll_interval_ms;
  int max_artifact_mib = static_cast<int>(o.workers.max_artifact_bytes >> 20);
  int max_samples_mib = static_cast<int>(o.workers.max_samples_bytes >> 20);
  int sample_cache_mib = static_cast<int>(o.sample_cache.max_stored_bytes >> 20);
  int compression_level = o.sample_cache.compression_level;
  int sample_cache_memory_mib = static_cast<int>(o.sample_cache.memory_bytes >> 20);
  int max_bundle_mib = static_cast<int>(o.limits.max_bundle_bytes >> 20);
  int max_jobs = o.limits.max_jobs_per_client;
  int max_message_mib = static_cast<int>(o.limits.max_message_bytes >> 20);
  int watch_poll_ms = o.limits.watch_poll_ms;
  int max_atlas_size = o.limits.max_atlas_size;
  int max_frames = o.limits.max_frames;
  std::string tokens_file = o.tokens_file.string(), tls_cert = o.tls_cert_file.string(),
              tls_key = o.tls_key_file.string(), tls_client_ca = o.tls_client_ca_file.string();
  bool allow_unauthenticated = o.allow_unauthenticated;
  const std::string listen0 = listen, data_dir0 = data_dir;
  const std::vector<int> ints0 = {lease_seconds,  max_wait_seconds,  poll_interval_ms, max_artifact_mib,
                                  max_samples_mib, sample_cache_mib, compression_level, max_bundle_mib,
                                  max_jobs,        max_message_mib,  watch_poll_ms,     max_atlas_size,
                                  max_frames,      sample_cache_memory_mib};

  FlagParser flags("server",
                   "Runs the mvbrdf job server: clients upload sequence bundles and submit jobs, workers lease\n"
                   "their tasks. State (SQLite database, bundles, artifacts, the Sample cache) lives in --data and\n"
                   "survives restarts. Settings: defaults, then --config FILE (JSON, mvbrdf.v1.ServerConfig), then\n"
                   "the flags. Prints 'listening on HOST:PORT' once ready; stops cleanly on SIGINT/SIGTERM.");
  flags.AddString("--config FILE", &config_path, "JSON config file (mvbrdf.v1.ServerConfig); flags override it");
  flags.AddString("--listen ADDR", &listen, "address to listen on, host:port (port 0: any free port)");
  flags.AddString("--data DIR", &data_dir, "the server's state directory (required, here or in the config)");
  flags.AddInt("--lease-seconds SECONDS", &lease_seconds, "how long a worker's task lease lasts without renewal");
  flags.AddInt("--max-wait-seconds SECONDS", &max_wait_seconds, "longest long poll of a worker asking for a task, s");
  flags.AddInt("--poll-interval-ms MS", &poll_interval_ms, "how often waiting workers' polls re-check the store");
  flags.AddInt("--max-artifact-mib MIB", &max_artifact_mib, "largest artifact a worker may send, MiB");
  flags.AddInt("--max-samples-mib MIB", &max_samples_mib, "largest encoded Samples a gather task may send, MiB");
  flags.AddInt("--sample-cache-mib MIB", &sample_cache_mib, "Sample cache size (compressed), MiB (0: unlimited)");
  flags.AddInt("--sample-cache-compression LEVEL", &compression_level, "Sample cache zlib level, 1 (fast) .. 9 (small)");
  flags.AddInt("--sample-cache-memory-mib MIB", &sample_cache_memory_mib,
               "keep the Sample set last stored or read uncompressed in memory up to this size, MiB, so that the "
               "sweep tasks fetch it without reading the database (0: never)");
  flags.AddInt("--max-bundle-mib MIB", &max_bundle_mib, "largest accepted bundle, MiB");
  flags.AddInt("--max-jobs-per-client N", &max_jobs, "unfinished jobs per client, at most (0: no limit)");
  flags.AddInt("--max-message-mib MIB", &max_message_mib, "largest gRPC message, MiB");
  flags.AddInt("--watch-poll-ms MS", &watch_poll_ms, "how often job watches re-read the store, ms");
  flags.AddInt("--max-atlas-size N", &max_atlas_size, "largest atlas a job may ask for, texels per side");
  flags.AddInt("--max-frames N", &max_frames, "most frames a job's sequence may have");
  flags.AddString("--tokens-file FILE", &tokens_file,
                  "bearer tokens, one 'role name token' a line (role: client, worker or admin); without it "
                  "every call is let in");
  flags.AddString("--tls-cert FILE", &tls_cert, "TLS certificate chain (PEM); with --tls-key the port speaks only TLS");
  flags.AddString("--tls-key FILE", &tls_key, "TLS private key (PEM)");
  flags.AddString("--tls-client-ca FILE", &tls_client_ca, "mutual TLS: clients need a certificate signed by this CA");
  flags.AddBool("--allow-unauthenticated", &allow_unauthenticated,
                "listen on a non-loopback address without --tokens-file (refused otherwise)");
  if (absl::Status s = flags.Parse(args); !s.ok()) return UsageError(s);
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }

  // One layer per changed flag, so that an error names the flag:
  // "--lease-seconds: lease_seconds: must be in [1, ...], got 0".
  struct Override {
    std::string flag;
    v1::ServerConfig config;
  };
  std::vector<Override> overrides;
  auto changed = [&overrides](const char* flag) -> v1::ServerConfig& {
    return overrides.emplace_back(Override{flag, {}}).config;
  };
  // Strings need no range checks: ServerOptions::Check names the flag.
  if (listen != listen0) o.listen_address = listen;
  if (data_dir != data_dir0) o.data_dir = data_dir;
  o.tokens_file = tokens_file;
  o.tls_cert_file = tls_cert;
  o.tls_key_file = tls_key;
  o.tls_client_ca_file = tls_client_ca;
  o.allow_unauthenticated = allow_unauthenticated;
  struct IntFlag {
    const char* name;
    int value;
    std::function<void(v1::ServerConfig&, uint64_t)> set;
  };
  const std::vector<IntFlag> ints = {
      {"--lease-seconds", lease_seconds, [](v1::ServerConfig& c, uint64_t v) { c.set_lease_seconds(v); }},
      {"--max-wait-seconds", max_wait_seconds, [](v1::ServerConfig& c, uint64_t v) { c.set_max_wait_seconds(v); }},
      {"--poll-interval-ms", poll_interval_ms, [](v1::ServerConfig& c, uint64_t v) { c.set_poll_interval_ms(v); }},
      {"--max-artifact-mib", max_artifact_mib,
       [](v1::ServerConfig& c, uint64_t v) { c.set_max_artifact_bytes(v << 20); }},
      {"--max-samples-mib", max_samples_mib,
       [](v1::ServerConfig& c, uint64_t v) { c.set_max_samples_bytes(v << 20); }},
      {"--sample-cache-mib", sample_cache_mib,
       [](v1::ServerConfig& c, uint64_t v) { c.set_sample_cache_max_bytes(v << 20); }},
      {"--sample-cache-compression", compression_level,
       [](v1::ServerConfig& c, uint64_t v) { c.set_sample_cache_compression_level(v); }},
      {"--max-bundle-mib", max_bundle_mib, [](v1::ServerConfig& c, uint64_t v) { c.set_max_bundle_bytes(v << 20); }},
      {"--max-jobs-per-client", max_jobs, [](v1::ServerConfig& c, uint64_t v) { c.set_max_jobs_per_client(v); }},
      {"--max-message-mib", max_message_mib,
       [](v1::ServerConfig& c, uint64_t v) { c.set_max_message_bytes(v << 20); }},
      {"--watch-poll-ms", watch_poll_ms, [](v1::ServerConfig& c, uint64_t v) { c.set_watch_poll_ms(v); }},
      {"--max-atlas-size", max_atlas_size, [](v1::ServerConfig& c, uint64_t v) { c.set_max_atlas_size(v); }},
      {"--max-frames", max_frames, [](v1::ServerConfig& c, uint64_t v) { c.set_max_frames(v); }},
      {"--sample-cache-memory-mib", sample_cache_memory_mib,
       [](v1::ServerConfig& c, uint64_t v) { c.set_sample_cache_memory_bytes(v << 20); }},
  };
  for (size_t i = 0; i < ints.size(); ++i) {
    if (ints[i].value == ints0[i]) continue;
    if (ints[i].value < 0) {
      return UsageError(absl::InvalidArgumentError(
          std::string(ints[i].name) + ": must be >= 0, got " + std::to_string(ints[i].value)));
    }
    ints[i].set(changed(ints[i].name), static_cast<uint64_t>(ints[i].value));
  }
  for (const Override& layer : overrides) {
    if (absl::Status s = server::ApplyServerConfig(layer.config, layer.flag, "", o); !s.ok()) return UsageError(s);
  }
  if (absl::Status s = o.Check(); !s.ok()) return UsageError(s);
  if (!o.tokens_file.empty()) {
    std::error_code ec;
    const std::filesystem::perms perms = std::filesystem::status(o.tokens_file, ec).permissions();
    using std::filesystem::perms;
    if (!ec && (perms & (perms::group_read | perms::others_read)) != perms::none) {
      std::fprintf(stderr,
                   "mvbrdf server: warning: %s is readable by other users: chmod 600 it, or keep only the tokens' "
                   "sha256: digests in it\n",
                   o.tokens_file.string().c_str());
    }
  }

  auto server = server::Server::Start(o);
  if (!server.ok()) return ReportFailure(server.status(), "mvbrdf server");
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  std::printf("listening on %s (data in %s; %s, %s)\n", (*server)->address().c_str(), o.data_dir.string().c_str(),
              (*server)->tls() ? "TLS" : "plaintext",
              (*server)->authenticating() ? "tokens required" : "no authentication");
  std::fflush(stdout);
  while (!g_stop) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::printf("shutting down\n");
  (*server)->Shutdown();
  return kExitOk;
}

}  // namespace mvbrdf::client
