#include <cstdio>

#include "client/commands.h"

namespace mvbrdf::client {

int ReportFailure(const absl::Status& status) {
  std::fprintf(stderr, "mvbrdf: error: %s\n", std::string(status.message()).c_str());
  switch (status.code()) {
    case absl::StatusCode::kInvalidArgument:
    case absl::StatusCode::kNotFound:
    case absl::StatusCode::kFailedPrecondition:
    case absl::StatusCode::kOutOfRange:
    case absl::StatusCode::kDataLoss:
      return kExitInvalidInput;
    case absl::StatusCode::kUnavailable:
    case absl::StatusCode::kPermissionDenied:
    case absl::StatusCode::kResourceExhausted:
      return kExitEnvironment;
    default:
      return kExitInternal;
  }
}

}  // namespace mvbrdf::client
