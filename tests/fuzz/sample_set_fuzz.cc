// libFuzzer target: DecodeSampleSet, the Samples cache and wire format that
// the server and the workers exchange (core/samples/sample_set.h).
//
// Any input must decode or fail with a Status, never crash or allocate more
// than the input justifies. A decoded set must be consistent (every array the
// length its counts say) and re-encode to the same number of bytes; a set of
// 32-bit floats re-encodes to the very same bytes.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "absl/strings/string_view.h"
#include "core/samples/sample_set.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

void Require(bool ok, const char* message) {
  if (ok) return;
  std::fprintf(stderr, "sample_set_fuzz: %s\n", message);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using mvbrdf::samples::DecodeSampleSet;
  using mvbrdf::samples::EncodeSampleSet;
  using mvbrdf::samples::SampleSet;
  const absl::string_view bytes(reinterpret_cast<const char*>(data), size);
  absl::StatusOr<SampleSet> set = DecodeSampleSet(bytes);
  mvbrdf::fuzz::Trace("DecodeSampleSet", set.status());
  if (!set.ok()) {
    Require(!set.status().message().empty(), "an error without a message");
    return 0;
  }
  const size_t n = set->size();
  const size_t num = static_cast<size_t>(set->num_lights());
  Require(num <= static_cast<size_t>(mvbrdf::samples::kMaxLights), "more than kMaxLights lights");
  Require(set->light_intensity.size() == num, "light_intensity and light_names differ in size");
  Require(set->frame.size() == n && set->camera.size() == n && set->reflectance.size() == n,
          "per-sample arrays of different lengths");
  Require(set->g.size() == n * num && set->h.size() == n * num, "g or h not samples x lights long");
  Require(set->falloff.empty() || set->falloff.size() == n * num, "falloff not samples x lights long");
  // Decoded memory is bounded by the input: every sample takes >= 13 bytes.
  Require(n <= size / 13, "more samples than the input can hold");

  // The accessors a fitter uses.
  const mvbrdf::samples::LightMask all =
      num == 0 ? 0u : static_cast<mvbrdf::samples::LightMask>((uint64_t{1} << num) - 1);
  for (size_t i = 0; i < n; ++i) {
    (void)set->Illumination(i, all);
    for (size_t k = 0; k < num; ++k) (void)set->Falloff(i, static_cast<int>(k));
  }
  (void)set->MaskOf(set->light_names);
  (void)set->MemoryBytes();

  // Re-encoding: flags bit 0 says which width the input used.
  const bool compact = (data[8] & 1u) != 0;
  const std::string again = EncodeSampleSet(*set, compact);
  Require(again.size() == size, "re-encoding changed the size");
  // Halves can differ (a signalling NaN comes back quiet); 32-bit floats are
  // copied bit for bit.
  if (!compact) Require(again == bytes, "re-encoding 32-bit floats changed the bytes");
  absl::StatusOr<SampleSet> twice = DecodeSampleSet(again);
  Require(twice.ok(), "a re-encoded set does not decode");
  Require(twice->element == set->element && twice->frame == set->frame && twice->camera == set->camera &&
              twice->light_names == set->light_names,
          "a re-encoded set decodes differently");
  return 0;
}
