#include "core/pipeline/memory_estimate.h"

#include <algorithm>
#include <limits>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/base/process_stats.h"
#include "core/pipeline/texel_illumination.h"
#include "core/samples/assemble.h"

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

LightLoad LightLoadOf(const scene::Sequence& sequence, int reservoir_slots, int pixel_footprint) {
  LightLoad load;
  load.num_lights = sequence.lights.size();
  load.max_lights_on = samples::MaxLightsOn(samples::FrameLightMasks(sequence), load.num_lights);
  load.num_configurations = 1 + static_cast<size_t>(sequence.scene.light_configurations_size());
  load.reservoir_slots = reservoir_slots;
  load.falloff = sequence.scene.lighting().inverse_square_falloff();
  load.pixel_footprint = pixel_footprint;
  return load;
}

uint64_t LightBytesPerTexel(const LightLoad& lights) {
  // The baseline was measured with one light: one shadow channel, one term.
  const uint64_t channels = (std::max<uint64_t>(lights.num_lights, 1) + 15) / 16;
  uint64_t bytes = 2 * (channels - 1) * sizeof(uint16_t);
  if (lights.reservoir_slots <= 0) return bytes;
  const size_t configurations = std::max<size_t>(lights.num_configurations, 1);
  bytes += TexelIllumination::BytesPerTexel(TexelIllumination::ChooseLayout(lights.num_lights, configurations),
                                            lights.num_lights, configurations);
  const uint64_t footprint = static_cast<uint64_t>(std::max(lights.pixel_footprint, 1));
  const uint64_t terms = footprint * footprint *
                         (lights.max_lights_on > 0 ? lights.max_lights_on : std::max<uint64_t>(lights.num_lights, 1));
  const bool falloff = lights.falloff || footprint > 1;
  const uint64_t per_term = 2 * sizeof(float) + sizeof(uint16_t) + (falloff ? sizeof(float) : 0);
  // Per texel its observation count, per slot a 12-byte header and the row.
  bytes +=
      sizeof(uint32_t) + static_cast<uint64_t>(lights.reservoir_slots) * (12 + 3 * sizeof(float) + terms * per_term);
  return bytes;
}

uint64_t EstimatedAtlasBytes(int atlas_size, const LightLoad& lights) {
  const uint64_t side = atlas_size > 0 ? static_cast<uint64_t>(atlas_size) : 0;
  return side * side * (kBytesPerAtlasTexel + LightBytesPerTexel(lights));
}

absl::Status CheckAtlasFitsInMemory(int atlas_size, const LightLoad& lights) {
  const char* limited_by = nullptr;
  const uint64_t available = AvailableMemoryBytes(&limited_by);
  const uint64_t needed = EstimatedAtlasBytes(atlas_size, lights);
  if (available == std::numeric_limits<uint64_t>::max() || needed <= available) return absl::OkStatus();
  return absl::ResourceExhaustedError(
      absl::StrCat("atlas ", atlas_size, "x", atlas_size, " needs about ", Mib(needed), " MiB",
                   LightBytesPerTexel(lights) > 0 ? absl::StrCat(" for ", lights.num_lights, " lights") : "",
                   ", but only ", Mib(available), " MiB are available (", limited_by, "); use a smaller --atlas"));
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
