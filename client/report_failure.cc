// Exit codes of failures, in one place: local Status failures and RPCs.
#include <cstdio>

#include <grpcpp/support/status.h>

#include "client/commands.h"
#include "core/scene/names.h"

namespace mvbrdf::client {

int ExitCodeFor(const absl::Status& status) {
  switch (status.code()) {
    case absl::StatusCode::kInvalidArgument:
    case absl::StatusCode::kNotFound:
    case absl::StatusCode::kFailedPrecondition:
    case absl::StatusCode::kOutOfRange:
    case absl::StatusCode::kDataLoss:
      return kExitInvalidInput;
    case absl::StatusCode::kUnauthenticated:  // only a server says so (e.g. to a worker)
      return kExitDenied;
    case absl::StatusCode::kUnavailable:
    case absl::StatusCode::kPermissionDenied:
    case absl::StatusCode::kResourceExhausted:
      return kExitEnvironment;
    default:
      return kExitInternal;
  }
}

int ReportFailure(const absl::Status& status, const std::string& command) {
  // Messages echo input (names, paths, flag values): control characters are
  // shown as \xNN, so none reaches the terminal (ESC) or cuts the line (NUL).
  std::fprintf(stderr, "%s: error: %s\n", command.c_str(), scene::ShownText(status.message()).c_str());
  return ExitCodeFor(status);
}

int ExitCodeForRpc(int grpc_code) {
  switch (static_cast<grpc::StatusCode>(grpc_code)) {
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::NOT_FOUND:
    case grpc::StatusCode::FAILED_PRECONDITION:
      return kExitInvalidInput;
    case grpc::StatusCode::UNAVAILABLE:
    case grpc::StatusCode::DEADLINE_EXCEEDED:
    case grpc::StatusCode::RESOURCE_EXHAUSTED:  // the server's disk or limits, as ExitCodeFor
      return kExitEnvironment;
    case grpc::StatusCode::UNAUTHENTICATED:
    case grpc::StatusCode::PERMISSION_DENIED:
      return kExitDenied;
    default:
      return kExitInternal;
  }
}

}  // namespace mvbrdf::client
