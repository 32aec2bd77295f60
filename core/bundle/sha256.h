// SHA-256 of a file, streamed (never the whole file in memory).
#ifndef MVBRDF_CORE_BUNDLE_SHA256_H_
#define MVBRDF_CORE_BUNDLE_SHA256_H_

#include <filesystem>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace mvbrdf::bundle {

// Lowercase hex digest (64 characters). NOT_FOUND when the file does not
// exist, INTERNAL for read errors.
absl::StatusOr<std::string> Sha256File(const std::filesystem::path& path);
// Lowercase hex digest of bytes in memory.
std::string Sha256Bytes(absl::string_view bytes);

}  // namespace mvbrdf::bundle

#endif  // MVBRDF_CORE_BUNDLE_SHA256_H_
