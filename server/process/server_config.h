// The server's configuration file (proto/mvbrdf/v1/server_config.proto) and
// how it becomes ServerOptions. Precedence, lowest first: built-in defaults,
// the file, command-line flags (client/server_command.cc applies the flags
// over the options this produces). Errors name the file and the field:
//   "server.json: lease_seconds: must be > 0, got 0".
#ifndef MVBRDF_SERVER_PROCESS_SERVER_CONFIG_H_
#define MVBRDF_SERVER_PROCESS_SERVER_CONFIG_H_

#include <filesystem>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "mvbrdf/v1/server_config.pb.h"
#include "server/process/server.h"

namespace mvbrdf::server {

// Reads the JSON file; INVALID_ARGUMENT naming the file for malformed JSON,
// an unknown field or a value of the wrong type; NOT_FOUND when missing.
absl::StatusOr<v1::ServerConfig> ReadServerConfig(const std::filesystem::path& path);

// Sets the fields present in `config` on `options` and checks the result.
// `origin` prefixes errors (the file name). A relative data_dir is taken
// relative to `base_dir` (the config file's directory; empty: as is).
absl::Status ApplyServerConfig(const v1::ServerConfig& config, absl::string_view origin,
                               const std::filesystem::path& base_dir, ServerOptions& options);

// ReadServerConfig then ApplyServerConfig with the file's name and directory.
absl::Status LoadServerConfig(const std::filesystem::path& path, ServerOptions& options);

}  // namespace mvbrdf::server

#endif  // MVBRDF_SERVER_PROCESS_SERVER_CONFIG_H_
