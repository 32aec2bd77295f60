#include "server/process/server_config.h"

#include <cstdint>
#include <limits>
#include <string>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"

namespace mvbrdf::server {
namespace {

absl::Status FieldError(absl::string_view origin, absl::string_view field, absl::string_view what) {
  return absl::InvalidArgumentError(absl::StrCat(origin, ": ", field, ": ", what));
}

// A uint32 field into an int option, at least `min`.
absl::Status SetInt(absl::string_view origin, absl::string_view field, uint32_t value, int64_t min, int* out) {
  if (value > static_cast<uint32_t>(std::numeric_limits<int>::max()) || static_cast<int64_t>(value) < min) {
    return FieldError(origin, field,
                      absl::StrCat("must be in [", min, ", ", std::numeric_limits<int>::max(), "], got ", value));
  }
  *out = static_cast<int>(value);
  return absl::OkStatus();
}

// A uint64 field into an int64 option, at least `min`.
absl::Status SetInt64(absl::string_view origin, absl::string_view field, uint64_t value, int64_t min,
                      int64_t* out) {
  if (value > static_cast<uint64_t>(std::numeric_limits<int64_t>::max()) || static_cast<int64_t>(value) < min) {
    return FieldError(origin, field,
                      absl::StrCat("must be in [", min, ", ", std::numeric_limits<int64_t>::max(), "], got ", value));
  }
  *out = static_cast<int64_t>(value);
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<v1::ServerConfig> ReadServerConfig(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat(path.string(), ": no such config file"));
  }
  v1::ServerConfig config;
  MVBRDF_RETURN_IF_ERROR(ReadJsonFile(path, &config));
  return config;
}

absl::Status ApplyServerConfig(const v1::ServerConfig& config, absl::string_view origin,
                               const std::filesystem::path& base_dir, ServerOptions& options) {
  if (config.has_listen_address()) {
    MVBRDF_RETURN_IF_ERROR(CheckListenAddress(config.listen_address(), absl::StrCat(origin, ": listen_address")));
    options.listen_address = config.listen_address();
  }
  if (config.has_data_dir()) {
    if (config.data_dir().empty()) return FieldError(origin, "data_dir", "must not be empty");
    std::filesystem::path dir(config.data_dir());
    options.data_dir = dir.is_relative() && !base_dir.empty() ? base_dir / dir : dir;
  }

  WorkersServiceOptions& workers = options.workers;
  if (config.has_lease_seconds()) {
    MVBRDF_RETURN_IF_ERROR(SetInt(origin, "lease_seconds", config.lease_seconds(), 1, &workers.lease_seconds));
  }
  if (config.has_max_wait_seconds()) {
    MVBRDF_RETURN_IF_ERROR(
        SetInt(origin, "max_wait_seconds", config.max_wait_seconds(), 0, &workers.max_wait_seconds));
  }
  if (config.has_max_artifact_bytes()) {
    MVBRDF_RETURN_IF_ERROR(
        SetInt64(origin, "max_artifact_bytes", config.max_artifact_bytes(), 1, &workers.max_artifact_bytes));
  }
  if (config.has_max_samples_bytes()) {
    MVBRDF_RETURN_IF_ERROR(
        SetInt64(origin, "max_samples_bytes", config.max_samples_bytes(), 1, &workers.max_samples_bytes));
  }
  if (config.has_poll_interval_ms()) {
    MVBRDF_RETURN_IF_ERROR(
        SetInt(origin, "poll_interval_ms", config.poll_interval_ms(), 1, &workers.poll_interval_ms));
  }

  store::SampleCacheOptions& cache = options.sample_cache;
  if (config.has_sample_cache_max_bytes()) {
    MVBRDF_RETURN_IF_ERROR(
        SetInt64(origin, "sample_cache_max_bytes", config.sample_cache_max_bytes(), 0, &cache.max_stored_bytes));
  }
  if (config.has_sample_cache_memory_bytes()) {
    MVBRDF_RETURN_IF_ERROR(
        SetInt64(origin, "sample_cache_memory_bytes", config.sample_cache_memory_bytes(), 0, &cache.memory_bytes));
  }
  if (config.has_sample_cache_compression_level()) {
    if (config.sample_cache_compression_level() < 1 || config.sample_cache_compression_level() > 9) {
      return FieldError(origin, "sample_cache_compression_level",
                        absl::StrCat("must be in [1, 9], got ", config.sample_cache_compression_level()));
    }
    cache.compression_level = static_cast<int>(config.sample_cache_compression_level());
  }

  clients_api::ServiceLimits& limits = options.limits;
  if (config.has_max_bundle_bytes()) {
    MVBRDF_RETURN_IF_ERROR(
        SetInt64(origin, "max_bundle_bytes", config.max_bundle_bytes(), 1, &limits.max_bundle_bytes));
  }
  if (config.has_max_jobs_per_client()) {
    MVBRDF_RETURN_IF_ERROR(
        SetInt(origin, "max_jobs_per_client", config.max_jobs_per_client(), 0, &limits.max_jobs_per_client));
  }
  if (config.has_max_message_bytes()) {
    MVBRDF_RETURN_IF_ERROR(
        SetInt64(origin, "max_message_bytes", config.max_message_bytes(), 1, &limits.max_message_bytes));
    // gRPC takes an int.
    if (limits.max_message_bytes > std::numeric_limits<int>::max() / 2) {
      return FieldError(origin, "max_message_bytes",
                        absl::StrCat("must be at most ", std::numeric_limits<int>::max() / 2, ", got ",
                                     limits.max_message_bytes));
    }
  }
  if (config.has_watch_poll_ms()) {
    MVBRDF_RETURN_IF_ERROR(SetInt(origin, "watch_poll_ms", config.watch_poll_ms(), 1, &limits.watch_poll_ms));
  }
  if (config.has_max_atlas_size()) {
    MVBRDF_RETURN_IF_ERROR(SetInt(origin, "max_atlas_size", config.max_atlas_size(), 16, &limits.max_atlas_size));
  }
  if (config.has_max_frames()) {
    MVBRDF_RETURN_IF_ERROR(SetInt(origin, "max_frames", config.max_frames(), 1, &limits.max_frames));
  }

  // Files, relative to the config file.
  const struct {
    const char* field;
    bool present;
    const std::string& value;
    std::filesystem::path* out;
  } files[] = {
      {"tokens_file", config.has_tokens_file(), config.tokens_file(), &options.tokens_file},
      {"tls_cert_file", config.has_tls_cert_file(), config.tls_cert_file(), &options.tls_cert_file},
      {"tls_key_file", config.has_tls_key_file(), config.tls_key_file(), &options.tls_key_file},
      {"tls_client_ca_file", config.has_tls_client_ca_file(), config.tls_client_ca_file(),
       &options.tls_client_ca_file},
  };
  for (const auto& file : files) {
    if (!file.present) continue;
    if (file.value.empty()) return FieldError(origin, file.field, "must not be empty (leave it out instead)");
    std::filesystem::path path(file.value);
    *file.out = path.is_relative() && !base_dir.empty() ? base_dir / path : path;
  }
  if (config.has_allow_unauthenticated()) options.allow_unauthenticated = config.allow_unauthenticated();
  // What the field checks above cannot see (e.g. max_message_bytes too small
  // for a chunk); these messages name the option, which is the field's name.
  for (const absl::Status& status : {limits.Check(), workers.Check()}) {
    if (!status.ok()) return absl::InvalidArgumentError(absl::StrCat(origin, ": ", status.message()));
  }
  return absl::OkStatus();
}

absl::Status LoadServerConfig(const std::filesystem::path& path, ServerOptions& options) {
  MVBRDF_ASSIGN_OR_RETURN(v1::ServerConfig config, ReadServerConfig(path));
  return ApplyServerConfig(config, path.string(), path.parent_path(), options);
}

}  // namespace mvbrdf::server
