// Samples (thesis §6.1.1, §6.2.2): one observation of a surface element — a
// triangle (light estimation) or a texel (reflectance) — in one frame by one
// camera, with the cosines of every candidate light.
//
// For sample i and light k (shared/NOTES.md):
//   g[i][k] = V_k * max(0, l_k . n)          visibility from the shadow atlas
//   h[i][k] = max(0, R(l_k) . v), 0 where g[i][k] = 0
//   the model: f_c = sum_{k in config} I_kc * ( kd_c g_k + ks_c a_k h_k^ke_c )
// with I_kc the light's intensity in channel c and a_k = 1/d_k^2 when the
// scene asks for inverse-square fall-off (point lights), else 1.
//
// Fall-off: a_k is folded into g (g[i][k] = a_k V_k max(0, l.n)), which is
// exact for the diffuse term and for Illumination(). It cannot be folded into
// h: the specular term needs a_k h^ke, and (a_k h)^ke = a_k^ke h^ke is wrong
// for every ke != 1 (a_k = 0.16 at 2.5 m and ke = 50 would scale highlights by
// 1e-40). So h stays the plain cosine and `falloff` holds a_k per sample and
// light; it is empty when fall-off is off (every a_k = 1, the thesis model),
// and a fitter multiplies the specular term by Falloff(i, k).
//
// Half-vector geometry (issue #15 item 2): the models of core/brdf other
// than the thesis's Phong read n.l, n.v, n.h and v.h (core/brdf/geometry.h).
// A set made with `half_vector` stores n.v per sample and n.h, v.h per term
// (h = normalize(l + v)); n.l of term j is g[j] / TermFalloff(j) (g holds
// the visibility, 0 or 1, times a_k l.n). Without it (the Phong path, the
// default) those arrays are empty and the set is what it was before.
//
// Stored as a structure of arrays so that fitters stream over contiguous
// values, and compactly (CSR): a sample holds only its terms, the lights that
// reach it (g != 0: visible, facing, on in its frame), so memory scales with
// the lights reaching a sample and not with the candidate count (an OLAT frame
// has one light on among hundreds). Sample i's terms are j in
// [offset[i], offset[i + 1]), with light[j] ascending, g[j], h[j] and
// falloff[j]. A light configuration selects lights by a LightMask, so one set
// serves the whole sweep.
#ifndef MVBRDF_CORE_SAMPLES_SAMPLE_SET_H_
#define MVBRDF_CORE_SAMPLES_SAMPLE_SET_H_

#include <cstdint>
#include <glm/glm.hpp>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/scene/light.h"

namespace mvbrdf::samples {

// Candidate lights per scene (scene::kMaxLights, validated with the scene).
constexpr int kMaxLights = scene::kMaxLights;

// A set of lights, bit k = light k, for any k < kMaxLights. The first 64 bits
// live inline, so masks of up to 64 lights copy without allocating.
class LightMask {
 public:
  LightMask() = default;
  // Lights 0..63 from the bits of `bits`.
  static LightMask FromBits(uint64_t bits) {
    LightMask m;
    m.low_ = bits;
    return m;
  }
  // Lights [0, n).
  static LightMask FirstN(size_t n);

  bool Test(size_t k) const {
    if (k < 64) return (low_ >> k) & 1u;
    const size_t w = k / 64 - 1;
    return w < high_.size() && ((high_[w] >> (k % 64)) & 1u);
  }
  void Set(size_t k);
  bool Any() const { return low_ != 0 || !high_.empty(); }  // high_ has no trailing zero words
  size_t Count() const;
  // One past the highest light in the set (0 for none).
  size_t End() const;
  // 64 lights [64 w, 64 w + 64).
  uint64_t Word(size_t w) const { return w == 0 ? low_ : (w - 1 < high_.size() ? high_[w - 1] : 0u); }
  size_t NumWords() const { return 1 + high_.size(); }
  // 16 lights [16 c, 16 c + 16): channel c of a shadow atlas (assemble.h).
  uint16_t Bits16(size_t c) const { return static_cast<uint16_t>(Word(c / 4) >> (16 * (c % 4))); }

  LightMask& operator|=(const LightMask& other);
  LightMask& operator&=(const LightMask& other);
  // The lights of this set that are not in `other` (this & ~other).
  LightMask Without(const LightMask& other) const;
  friend LightMask operator|(LightMask a, const LightMask& b) { return a |= b; }
  friend LightMask operator&(LightMask a, const LightMask& b) { return a &= b; }
  friend bool operator==(const LightMask& a, const LightMask& b) { return a.low_ == b.low_ && a.high_ == b.high_; }
  friend bool operator!=(const LightMask& a, const LightMask& b) { return !(a == b); }

  // Calls f(k) for every light k in the set, ascending.
  template <typename F>
  void ForEach(F&& f) const {
    for (size_t w = 0; w < NumWords(); ++w) {
      for (uint64_t bits = Word(w); bits != 0; bits &= bits - 1) f(64 * w + static_cast<size_t>(__builtin_ctzll(bits)));
    }
  }
  // Hexadecimal, light 0 in the lowest bit ("0x5" = lights 0 and 2).
  std::string ToString() const;
  friend std::ostream& operator<<(std::ostream& out, const LightMask& m) { return out << m.ToString(); }

 private:
  void Trim();
  uint64_t low_ = 0;
  std::vector<uint64_t> high_;  // lights 64.., no trailing zero words
};

// The lights a configuration selects in each Sample: `config` in a frame
// without its own lights, every light in a frame with its own
// (scene.frame_lighting; FrameStream already dropped the lights off in it, so
// its Samples hold exactly its own lights' terms). Implicit from a mask: no
// frame has its own lights. `own` is per frame (samples::OwnLightingFrames),
// derived from the scene, so a SampleSet's encoding need not carry it.
struct LightSelection {
  LightSelection(LightMask mask) : config(std::move(mask)) {}  // NOLINT: implicit
  LightSelection(LightMask mask, std::vector<uint8_t> own_frames)
      : config(std::move(mask)), own(std::move(own_frames)) {}
  bool Own(size_t frame) const { return frame < own.size() && own[frame] != 0; }
  // Whether light k counts in a Sample of `frame`.
  bool Selects(size_t frame, size_t k) const { return Own(frame) || config.Test(k); }
  // The mask of `frame`'s Samples (`all`: every light of the set).
  const LightMask& Of(size_t frame, const LightMask& all) const { return Own(frame) ? all : config; }

  LightMask config;
  std::vector<uint8_t> own;
};

// The half-vector geometry of one Sample as AddTerms takes it: n.v, and
// n.h, v.h per term (null: none given).
struct HalfVectorTerms {
  float n_dot_v = 0.0f;
  const float* n_dot_h = nullptr;
  const float* v_dot_h = nullptr;
};

struct SampleSet {
  // The candidate lights, in the scene's order.
  std::vector<std::string> light_names;
  std::vector<glm::vec3> light_intensity;  // linear RGB per light

  // Per sample.
  std::vector<uint32_t> element;       // triangle id or texel index (row * size + column)
  std::vector<uint16_t> frame;         // 0-based frame of the sequence
  std::vector<uint8_t> camera;         // camera index
  std::vector<glm::vec3> reflectance;  // linear RGB
  // size() + 1 values: sample i's terms are [offset[i], offset[i + 1]).
  std::vector<uint64_t> offset = {0};
  // Per term: the light (ascending within a sample), g and h.
  std::vector<uint16_t> light;
  std::vector<float> g;
  std::vector<float> h;
  // Per term: a_k (see above), or empty: no fall-off (all 1).
  std::vector<float> falloff;
  // Whether the set stores the half-vector geometry (see above): then
  // n_dot_v has size() values and n_dot_h, v_dot_h num_terms() values; else
  // all three are empty.
  bool half_vector = false;
  std::vector<float> n_dot_v;  // per sample
  std::vector<float> n_dot_h;  // per term
  std::vector<float> v_dot_h;  // per term

  int num_lights() const { return static_cast<int>(light_names.size()); }
  size_t size() const { return element.size(); }
  size_t num_terms() const { return light.size(); }
  // Sample i's terms: j in [TermsBegin(i), TermsEnd(i)).
  size_t TermsBegin(size_t i) const { return static_cast<size_t>(offset[i]); }
  size_t TermsEnd(size_t i) const { return static_cast<size_t>(offset[i + 1]); }
  // Appends one sample from dense rows: `g` and `h` hold num_lights() values
  // each, and `falloff_row` too when given (nullptr: a_k = 1; `falloff` stays
  // empty until the first sample with fall-off, then earlier terms get 1s).
  // Only the lights with g != 0 become terms (a non-finite g is kept so that
  // fitters see and skip it; a finite g <= 0 adds nothing to the model).
  void Add(uint32_t element_id, int frame_index, int camera_index, const glm::vec3& rgb, const float* g_row,
           const float* h_row, const float* falloff_row = nullptr);
  // Appends one sample from `count` terms (lights ascending, < num_lights()),
  // dropping g = 0 terms as Add does. A half_vector set requires `geometry`
  // (n_dot_h and v_dot_h for the `count` terms); another ignores it. Add's
  // dense rows carry none, so Add requires a set without half_vector.
  void AddTerms(uint32_t element_id, int frame_index, int camera_index, const glm::vec3& rgb, size_t count,
                const uint16_t* lights, const float* g_terms, const float* h_terms,
                const float* falloff_terms = nullptr, const HalfVectorTerms& geometry = {});
  // a_k of term j (1 without fall-off).
  float TermFalloff(size_t j) const { return falloff.empty() ? 1.0f : falloff[j]; }
  // g of light k in sample i (0 when k does not reach it); a search over the
  // sample's terms, for tests and reports, not for fitters.
  float GOf(size_t i, int k) const;
  float HOf(size_t i, int k) const;
  // Mask of the named lights; INVALID_ARGUMENT names an unknown one.
  absl::StatusOr<LightMask> MaskOf(const std::vector<std::string>& names) const;
  // Sum over the lights in `mask` of I_k g_k: the diffuse illumination of
  // sample i per channel.
  glm::vec3 Illumination(size_t i, const LightSelection& lights) const;
  // Bytes held (for reports and cache limits).
  size_t MemoryBytes() const;
};

// Versioned binary encoding (little-endian): a header with magic "MVSS",
// version (3: version 2's compact terms and, flagged, the half-vector
// geometry), counts and light names/intensities, then the arrays;
// reflectance, g, h (and falloff, n.v, n.h, v.h when present) as 16-bit halves
// when `compact`, else 32-bit floats (layout in sample_set.cc). Version 2
// (the same without half-vector geometry) is still read. Version 1 (dense
// rows of at most 16 lights) is refused with DATA_LOSS: a cache holding one
// treats it as a miss and recomputes (server/workers_api). The encoding
// is the cache and wire format (issue #5), so it fails loudly on anything
// unexpected.
std::string EncodeSampleSet(const SampleSet& set, bool compact = true);
// DATA_LOSS naming what is wrong (magic, version, truncation, counts) for a
// corrupt, foreign or outdated buffer.
absl::StatusOr<SampleSet> DecodeSampleSet(absl::string_view bytes);

// An encoding's header: what DecodeSampleSet would read, without the arrays.
struct SampleSetHeader {
  bool compact = false;
  bool has_falloff = false;
  bool half_vector = false;
  std::vector<std::string> light_names;
  std::vector<glm::vec3> light_intensity;
  size_t num_samples = 0;
  size_t num_terms = 0;
};
// The header, its light table and the arrays' total size checked (the same
// DATA_LOSS errors as DecodeSampleSet's for those), without decoding or
// validating the arrays themselves: what a cache hit needs to describe its
// Samples (server/workers_api), in microseconds instead of a full decode.
absl::StatusOr<SampleSetHeader> ReadSampleSetHeader(absl::string_view bytes);

}  // namespace mvbrdf::samples

#endif  // MVBRDF_CORE_SAMPLES_SAMPLE_SET_H_
