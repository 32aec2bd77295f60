#include "core/pipeline/memory_estimate.h"

#include <limits>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/base/process_stats.h"

namespace mvbrdf::pipeline {
namespace {

uint64_t Mib(uint64_t bytes) { return (bytes + (uint64_t{1} << 20) - 1) >> 20; }

}  // namespace

namespace internal {
bool IsUnnamedOutOfMemory(const absl::Status& status) {
  return absl::IsResourceExhausted(status) && absl::StrContains(status.message(), "out of memory") &&
         !absl::StrContains(status.message(), "needs about");
}
}  // namespace internal

uint64_t EstimatedAtlasBytes(int atlas_size) {
  const uint64_t side = atlas_size > 0 ? static_cast<uint64_t>(atlas_size) : 0;
  return side * side * kBytesPerAtlasTexel;
}

absl::Status CheckAtlasFitsInMemory(int atlas_size) {
  const char* limited_by = nullptr;
  const uint64_t available = AvailableMemoryBytes(&limited_by);
  const uint64_t needed = EstimatedAtlasBytes(atlas_size);
  if (available == std::numeric_limits<uint64_t>::max() || needed <= available) return absl::OkStatus();
  return absl::ResourceExhaustedError(absl::StrCat("atlas ", atlas_size, "x", atlas_size, " needs about ", Mib(needed),
                                                   " MiB, but only ", Mib(available), " MiB are available (",
                                                   limited_by, "); use a smaller --atlas"));
}

absl::Status OutOfMemoryError(absl::string_view what, int atlas_size, absl::string_view detail) {
  if (atlas_size <= 0) return absl::ResourceExhaustedError(absl::StrCat(what, ": out of memory (", detail, ")"));
  const char* limited_by = nullptr;
  const uint64_t available = AvailableMemoryBytes(&limited_by);
  return absl::ResourceExhaustedError(
      absl::StrCat(what, ": out of memory: atlas ", atlas_size, "x", atlas_size, " needs about ",
                   Mib(EstimatedAtlasBytes(atlas_size)), " MiB",
                   available == std::numeric_limits<uint64_t>::max()
                       ? ""
                       : absl::StrCat(", ", Mib(available), " MiB are left (", limited_by, ")"),
                   "; use a smaller --atlas (", detail, ")"));
}

}  // namespace mvbrdf::pipeline
