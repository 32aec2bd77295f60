#include "server/process/server_config.h"

#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "server/store/test_dir.h"

namespace mvbrdf::server {
namespace {

std::filesystem::path WriteConfig(const store::TestDir& dir, const std::string& json) {
  const std::filesystem::path path = dir.path() / "server.json";
  std::ofstream(path) << json;
  return path;
}

TEST(ServerConfigTest, ValidFileSetsEveryField) {
  store::TestDir dir;
  const auto path = WriteConfig(dir, R"json({
    "listen_address": "0.0.0.0:7000",
    "dataDir": "state",
    "lease_seconds": 45,
    "max_wait_seconds": 5,
    "max_artifact_bytes": 1048576,
    "max_samples_bytes": "2147483648",
    "poll_interval_ms": 100,
    "sample_cache_max_bytes": 0,
    "sample_cache_compression_level": 9,
    "sample_cache_memory_bytes": 0,
    "max_bundle_bytes": 1073741824,
    "max_jobs_per_client": 0,
    "max_message_bytes": 8388608,
    "watch_poll_ms": 50,
    "max_atlas_size": 2048,
    "max_frames": 5000,
    "tokens_file": "tokens.txt",
    "tls_cert_file": "/etc/mvbrdf/server.pem",
    "tls_key_file": "server.key",
    "tls_client_ca_file": "ca.pem",
    "allow_unauthenticated": true
  })json");
  ServerOptions options;
  const absl::Status status = LoadServerConfig(path, options);
  ASSERT_TRUE(status.ok()) << status;
  EXPECT_EQ(options.listen_address, "0.0.0.0:7000");
  EXPECT_EQ(options.data_dir, dir.path() / "state");  // relative to the file
  EXPECT_EQ(options.workers.lease_seconds, 45);
  EXPECT_EQ(options.workers.max_wait_seconds, 5);
  EXPECT_EQ(options.workers.max_artifact_bytes, 1 << 20);
  EXPECT_EQ(options.workers.max_samples_bytes, int64_t{2} << 30);
  EXPECT_EQ(options.workers.poll_interval_ms, 100);
  EXPECT_EQ(options.sample_cache.max_stored_bytes, 0);
  EXPECT_EQ(options.sample_cache.compression_level, 9);
  EXPECT_EQ(options.sample_cache.memory_bytes, 0);  // present: never kept (the default keeps up to 256 MiB)
  EXPECT_EQ(options.limits.max_bundle_bytes, int64_t{1} << 30);
  EXPECT_EQ(options.limits.max_jobs_per_client, 0);  // present: no limit
  EXPECT_EQ(options.limits.max_message_bytes, 8 << 20);
  EXPECT_EQ(options.limits.watch_poll_ms, 50);
  EXPECT_EQ(options.limits.max_atlas_size, 2048);
  EXPECT_EQ(options.limits.max_frames, 5000);
  EXPECT_EQ(options.tokens_file, dir.path() / "tokens.txt");
  EXPECT_EQ(options.tls_cert_file, "/etc/mvbrdf/server.pem");
  EXPECT_EQ(options.tls_key_file, dir.path() / "server.key");
  EXPECT_EQ(options.tls_client_ca_file, dir.path() / "ca.pem");
  EXPECT_TRUE(options.allow_unauthenticated);
  EXPECT_TRUE(options.Check().ok());
}

// Without tokens the server listens only where no other machine reaches it,
// unless told otherwise; TLS files come in pairs.
TEST(ServerConfigTest, NonLoopbackWithoutTokensIsRefusedUnlessAllowed) {
  ServerOptions options;
  options.data_dir = "/tmp/unused";
  for (const char* local : {"127.0.0.1:0", "localhost:7000", "[::1]:7000", "unix:/tmp/mvbrdf.sock"}) {
    options.listen_address = local;
    EXPECT_TRUE(options.Check().ok()) << local << ": " << options.Check();
  }
  for (const char* open : {"0.0.0.0:7000", "[::]:7000", "10.1.2.3:7000", "example.org:7000"}) {
    options.listen_address = open;
    const absl::Status refused = options.Check();
    EXPECT_EQ(refused.code(), absl::StatusCode::kFailedPrecondition) << open;
    EXPECT_NE(refused.message().find("--allow-unauthenticated"), std::string::npos) << refused;
  }
  options.allow_unauthenticated = true;
  EXPECT_TRUE(options.Check().ok());
  options.allow_unauthenticated = false;
  options.tokens_file = "/etc/mvbrdf/tokens";
  EXPECT_TRUE(options.Check().ok());

  options.tls_cert_file = "server.pem";
  EXPECT_NE(options.Check().message().find("--tls-cert, --tls-key"), std::string::npos);
  options.tls_key_file = "server.key";
  EXPECT_TRUE(options.Check().ok());
  options.tls_cert_file.clear();
  options.tls_key_file.clear();
  options.tls_client_ca_file = "ca.pem";
  EXPECT_NE(options.Check().message().find("--tls-client-ca"), std::string::npos);
}

TEST(ServerConfigTest, AbsentFieldsKeepTheDefaults) {
  store::TestDir dir;
  const auto path = WriteConfig(dir, R"json({"data_dir": "/var/lib/mvbrdf"})json");
  ServerOptions options;
  ASSERT_TRUE(LoadServerConfig(path, options).ok());
  const ServerOptions defaults;
  EXPECT_EQ(options.data_dir, "/var/lib/mvbrdf");
  EXPECT_EQ(options.listen_address, defaults.listen_address);
  EXPECT_EQ(options.workers.lease_seconds, defaults.workers.lease_seconds);
  EXPECT_EQ(options.limits.max_jobs_per_client, defaults.limits.max_jobs_per_client);
  EXPECT_EQ(options.sample_cache.max_stored_bytes, defaults.sample_cache.max_stored_bytes);
}

TEST(ServerConfigTest, UnknownFieldNamesTheFileAndTheField) {
  store::TestDir dir;
  const auto path = WriteConfig(dir, R"json({"lease_seconds": 10, "lease_secs": 10})json");
  ServerOptions options;
  const absl::Status status = LoadServerConfig(path, options);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find(path.string()), absl::string_view::npos) << status;
  EXPECT_NE(status.message().find("lease_secs"), absl::string_view::npos) << status;
}

TEST(ServerConfigTest, WrongTypeNamesTheFileAndTheField) {
  store::TestDir dir;
  const auto path = WriteConfig(dir, R"json({"max_wait_seconds": "soon"})json");
  ServerOptions options;
  const absl::Status status = LoadServerConfig(path, options);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find(path.string()), absl::string_view::npos) << status;
  EXPECT_NE(status.message().find("max_wait_seconds"), absl::string_view::npos) << status;
}

TEST(ServerConfigTest, BadValuesNameTheFileAndTheField) {
  store::TestDir dir;
  for (const auto& [json, field] : std::vector<std::pair<std::string, std::string>>{
           {R"json({"lease_seconds": 0})json", "lease_seconds"},
           {R"json({"listen_address": "nonsense"})json", "listen_address"},
           {R"json({"max_samples_bytes": "18446744073709551615"})json", "max_samples_bytes"},
           {R"json({"sample_cache_compression_level": 10})json", "sample_cache_compression_level"},
           {R"json({"sample_cache_memory_bytes": "18446744073709551615"})json", "sample_cache_memory_bytes"},
           {R"json({"max_message_bytes": 100})json", "max_message_bytes"},
       }) {
    const auto path = WriteConfig(dir, json);
    ServerOptions options;
    const absl::Status status = LoadServerConfig(path, options);
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << json;
    EXPECT_NE(status.message().find(path.string() + ": " + field), absl::string_view::npos) << status;
  }
  ServerOptions options;
  EXPECT_EQ(LoadServerConfig(dir.path() / "missing.json", options).code(), absl::StatusCode::kNotFound);
}

// `mvbrdf server --config FILE --lease-seconds 5 --listen ...`: the command
// applies each changed flag over the file as one more layer (named after the
// flag); only what the flags set changes.
TEST(ServerConfigTest, FlagsOverrideTheFile) {
  store::TestDir dir;
  const auto path = WriteConfig(dir, R"json({"lease_seconds": 45, "max_jobs_per_client": 3,
                                             "data_dir": "/srv/mvbrdf"})json");
  ServerOptions options;
  ASSERT_TRUE(LoadServerConfig(path, options).ok());
  v1::ServerConfig lease_flag;
  lease_flag.set_lease_seconds(5);
  ASSERT_TRUE(ApplyServerConfig(lease_flag, "--lease-seconds", "", options).ok());
  v1::ServerConfig listen_flag;
  listen_flag.set_listen_address("127.0.0.1:9000");
  ASSERT_TRUE(ApplyServerConfig(listen_flag, "--listen", "", options).ok());
  EXPECT_EQ(options.workers.lease_seconds, 5);
  EXPECT_EQ(options.listen_address, "127.0.0.1:9000");
  EXPECT_EQ(options.limits.max_jobs_per_client, 3);  // from the file
  EXPECT_EQ(options.data_dir, "/srv/mvbrdf");
  lease_flag.set_lease_seconds(0);
  const absl::Status bad = ApplyServerConfig(lease_flag, "--lease-seconds", "", options);
  EXPECT_NE(bad.message().find("--lease-seconds: lease_seconds"), absl::string_view::npos) << bad;
}

}  // namespace
}  // namespace mvbrdf::server
