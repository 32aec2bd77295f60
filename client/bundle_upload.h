// Uploading a sequence bundle to a server (`mvbrdf submit`, and `mvbrdf run`
// to its in-process server): asks what the server has, sends the rest in
// 1 MiB chunks (resuming a partial upload) and checks the server verified it.
#ifndef MVBRDF_CLIENT_BUNDLE_UPLOAD_H_
#define MVBRDF_CLIENT_BUNDLE_UPLOAD_H_

#include <cstdint>
#include <filesystem>
#include <string>

#include "absl/status/status.h"
#include "client/progress.h"
#include "mvbrdf/v1/service.grpc.pb.h"

namespace mvbrdf::client {

struct UploadOutcome {
  bool already_there = false;  // nothing was sent
  uint64_t resumed_at = 0;     // bytes the server had from an earlier upload
};

// Failures carry the RPC's status code (the same numbers as absl's) and a
// message naming the step; local read errors are DATA_LOSS / UNAVAILABLE.
// `progress` may be null.
absl::Status UploadBundleFile(v1::Mvbrdf::Stub& stub, const std::string& client_name,
                              const std::filesystem::path& archive, const std::string& sha256, uint64_t size,
                              ProgressPrinter* progress, UploadOutcome* outcome);

}  // namespace mvbrdf::client

#endif  // MVBRDF_CLIENT_BUNDLE_UPLOAD_H_
