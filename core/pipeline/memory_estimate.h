// Memory for an atlas, estimated up front, and allocations that fail turned
// into a Status (issue #19: `resample --atlas 8192` under a memory limit, or
// a worker at the server's own allowed --atlas 4096, aborted in an
// allocation instead of failing with a reason).
//
// The estimate: resampling a scene keeps about kBytesPerAtlasTexel bytes per
// texel of the atlas on top of the scene itself (position, normal, per-camera
// and accumulated atlas images, float RGB(A)); measured with `mvbrdf
// resample` of a 3-camera synthetic scene: peak RSS 683 MiB at 1024²,
// 1158 MiB at 2048², 3062 MiB at 4096², i.e. 158 B per texel. A run's later
// stages need more, so this is a lower bound: a check against it refuses
// only what cannot fit.
#ifndef MVBRDF_CORE_PIPELINE_MEMORY_ESTIMATE_H_
#define MVBRDF_CORE_PIPELINE_MEMORY_ESTIMATE_H_

#include <cstdint>
#include <new>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace mvbrdf::pipeline {

inline constexpr uint64_t kBytesPerAtlasTexel = 160;

// About how many bytes resampling with an atlas of `atlas_size`² texels needs.
uint64_t EstimatedAtlasBytes(int atlas_size);

// RESOURCE_EXHAUSTED "atlas 8192x8192 needs about 10240 MiB, but only 1900
// MiB are available (ulimit -v)" when the estimate exceeds
// AvailableMemoryBytes(); OK otherwise (and when nothing is known).
absl::Status CheckAtlasFitsInMemory(int atlas_size);

// RESOURCE_EXHAUSTED for an allocation that failed while running `what`
// ("resample", "task gather") with an atlas of `atlas_size` (0: unknown).
absl::Status OutOfMemoryError(absl::string_view what, int atlas_size, absl::string_view detail);

namespace internal {
inline const absl::Status& StatusOf(const absl::Status& status) { return status; }
template <typename T>
const absl::Status& StatusOf(const absl::StatusOr<T>& status_or) {
  return status_or.status();
}
// RESOURCE_EXHAUSTED "... out of memory" (e.g. GL_OUT_OF_MEMORY) that does
// not say the atlas size yet.
bool IsUnnamedOutOfMemory(const absl::Status& status);
}  // namespace internal

// Runs f() (returning absl::Status or absl::StatusOr<T>); std::bad_alloc,
// std::length_error and OpenCV's out-of-memory cv::Exception become
// OutOfMemoryError, any other cv::Exception INTERNAL with its message; an
// out-of-memory Status f() returns (GL_OUT_OF_MEMORY) gets the atlas size.
template <typename F>
auto CatchOutOfMemory(absl::string_view what, int atlas_size, F&& f) -> decltype(f()) {
  try {
    auto result = f();
    if (!result.ok() && internal::IsUnnamedOutOfMemory(internal::StatusOf(result))) {
      return OutOfMemoryError(what, atlas_size, internal::StatusOf(result).message());
    }
    return result;
  } catch (const std::bad_alloc& e) {
    return OutOfMemoryError(what, atlas_size, e.what());
  } catch (const std::length_error& e) {
    return OutOfMemoryError(what, atlas_size, e.what());
  } catch (const cv::Exception& e) {
    if (e.code == cv::Error::StsNoMem) return OutOfMemoryError(what, atlas_size, e.err);
    return absl::InternalError(std::string(what) + ": OpenCV: " + e.what());
  }
}

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_MEMORY_ESTIMATE_H_
