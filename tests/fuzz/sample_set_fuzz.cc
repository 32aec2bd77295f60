// libFuzzer target: DecodeSampleSet (and ReadSampleSetHeader), the Samples
// cache and wire format that the server and the workers exchange
// (core/samples/sample_set.h).
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
  // The header alone (a cache hit's description) never crashes either, and
  // agrees with every set that decodes.
  absl::StatusOr<mvbrdf::samples::SampleSetHeader> header = mvbrdf::samples::ReadSampleSetHeader(bytes);
  Require(header.ok() || !header.status().message().empty(), "a header error without a message");
  if (!set.ok()) {
    Require(!set.status().message().empty(), "an error without a message");
    return 0;
  }
  Require(header.ok() && header->num_samples == set->size() && header->num_terms == set->num_terms() &&
              header->light_names == set->light_names,
          "a set decodes but its header disagrees");
  const size_t n = set->size();
  const size_t num = static_cast<size_t>(set->num_lights());
  Require(num <= static_cast<size_t>(mvbrdf::samples::kMaxLights), "more than kMaxLights lights");
  Require(set->light_intensity.size() == num, "light_intensity and light_names differ in size");
  Require(set->frame.size() == n && set->camera.size() == n && set->reflectance.size() == n,
          "per-sample arrays of different lengths");
  const size_t terms = set->num_terms();
  Require(set->offset.size() == n + 1 && set->offset.front() == 0 && set->offset.back() == terms,
          "offsets do not span the terms");
  Require(set->g.size() == terms && set->h.size() == terms, "g or h not one per term");
  Require(set->falloff.empty() || set->falloff.size() == terms, "falloff not one per term");
  Require(set->half_vector ? set->n_dot_v.size() == n && set->n_dot_h.size() == terms && set->v_dot_h.size() == terms
                           : set->n_dot_v.empty() && set->n_dot_h.empty() && set->v_dot_h.empty(),
          "half-vector arrays do not match the flag");
  // Decoded memory is bounded by the input: every sample takes >= 15 bytes,
  // every term >= 6.
  Require(n <= size / 15 && terms <= size / 6, "more samples or terms than the input can hold");
  for (size_t i = 0; i < n; ++i) {
    Require(set->TermsBegin(i) <= set->TermsEnd(i) && set->TermsEnd(i) - set->TermsBegin(i) <= num,
            "a sample with more terms than lights");
    for (size_t j = set->TermsBegin(i); j < set->TermsEnd(i); ++j) {
      Require(set->light[j] < num && (j == set->TermsBegin(i) || set->light[j] > set->light[j - 1]),
              "a sample's lights not ascending below num_lights");
    }
  }

  // The accessors a fitter uses.
  const mvbrdf::samples::LightMask all = mvbrdf::samples::LightMask::FirstN(num);
  for (size_t i = 0; i < n; ++i) (void)set->Illumination(i, all);
  for (size_t j = 0; j < terms; ++j) (void)set->TermFalloff(j);
  (void)set->MaskOf(set->light_names);
  (void)set->MemoryBytes();

  // Re-encoding: flags bit 0 says which width the input used.
  const bool compact = (data[8] & 1u) != 0;
  const std::string again = EncodeSampleSet(*set, compact);
  Require(again.size() == size, "re-encoding changed the size");
  // Halves can differ (a signalling NaN comes back quiet); 32-bit floats are
  // copied bit for bit, but for the version: a version 2 input (still read)
  // is written as version 3.
  std::string expected(bytes);
  if (expected[4] == 2) expected[4] = 3;
  if (!compact) Require(again == expected, "re-encoding 32-bit floats changed the bytes");
  absl::StatusOr<SampleSet> twice = DecodeSampleSet(again);
  Require(twice.ok(), "a re-encoded set does not decode");
  Require(twice->element == set->element && twice->frame == set->frame && twice->camera == set->camera &&
              twice->light_names == set->light_names,
          "a re-encoded set decodes differently");
  return 0;
}
