// Memory for an atlas, estimated up front, and allocations that fail turned
// into a Status (issue #19: `resample --atlas 8192` under a memory limit, or
// a worker at the server's own allowed --atlas 4096, aborted in an
// allocation instead of failing with a reason).
//
// The estimate: resampling a scene keeps about kBytesPerAtlasTexel bytes per
// texel of the atlas on top of the scene itself (position, normal, per-camera
// and accumulated atlas images, float RGB(A)); measured with `mvbrdf
// resample` of a 3-camera synthetic scene: peak RSS 683 MiB at 1024²,
// 1158 MiB at 2048², 3062 MiB at 4096², i.e. 158 B per texel. What grows
// with the light count is added (LightLoad; issue #13: at 256 lights pass 1's
// per-light sums alone were 1 KiB per texel). A run's later stages need more,
// so this is a lower bound: a check against it refuses only what cannot fit.
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
#include "core/scene/sequence.h"

namespace mvbrdf::pipeline {

inline constexpr uint64_t kBytesPerAtlasTexel = 160;

// What grows with the lights, per atlas texel, on top of kBytesPerAtlasTexel
// (measured with one light):
//  - the shadow atlas, ceil(L / 16) 16-bit channels, twice (the frame's
//    read-back and the stream's copy);
//  - with the texel pass (run, the gather task): pass 1's illumination sums
//    (TexelIllumination::BytesPerTexel of the layout it chooses) and the
//    reservoir's kept Samples, `reservoir_slots` x (3 + 2M floats + M u16, one
//    more float per term with fall-off or a pixel footprint), M = the most
//    lights on in one frame (times pixel_footprint^2).
struct LightLoad {
  size_t num_lights = 0;          // candidate lights
  size_t max_lights_on = 0;       // terms per Sample (0: num_lights)
  size_t num_configurations = 1;  // the scene's light configurations + "all lights"
  int reservoir_slots = 0;        // 0: no texel pass (resample)
  bool falloff = false;           // inverse-square fall-off (a_k kept per term)
  int pixel_footprint = 1;        // ReconstructOptions::pixel_footprint: footprint^2 terms per light
};

// The load of `sequence` as a run with `reservoir_slots` reservoir slots per
// texel (0: resampling only) gathers it.
LightLoad LightLoadOf(const scene::Sequence& sequence, int reservoir_slots, int pixel_footprint = 1);

// Bytes per atlas texel for `lights` beyond kBytesPerAtlasTexel.
uint64_t LightBytesPerTexel(const LightLoad& lights);

// About how many bytes resampling with an atlas of `atlas_size`² texels needs,
// with `lights` (default: none beyond the baseline's one).
uint64_t EstimatedAtlasBytes(int atlas_size, const LightLoad& lights = {});

// RESOURCE_EXHAUSTED "atlas 8192x8192 needs about 10240 MiB, but only 1900
// MiB are available (ulimit -v)" when the estimate exceeds
// AvailableMemoryBytes(); OK otherwise (and when nothing is known). When the
// lights add to the estimate the message says how many ("... MiB for 256
// lights, but only ...").
absl::Status CheckAtlasFitsInMemory(int atlas_size, const LightLoad& lights = {});

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
