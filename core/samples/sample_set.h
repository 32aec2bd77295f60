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
// Stored as a structure of arrays so that fitters stream over contiguous
// floats; a light configuration selects lights by a bit mask, so one set
// serves the whole sweep.
#ifndef MVBRDF_CORE_SAMPLES_SAMPLE_SET_H_
#define MVBRDF_CORE_SAMPLES_SAMPLE_SET_H_

#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/scene/light.h"

namespace mvbrdf::samples {

constexpr int kMaxLights = scene::kMaxLights;  // validation refuses more (core/scene/light.h)
// Bit k = light k of the set.
using LightMask = uint32_t;

struct SampleSet {
  // The candidate lights, in the scene's order.
  std::vector<std::string> light_names;
  std::vector<glm::vec3> light_intensity;  // linear RGB per light

  // Per sample.
  std::vector<uint32_t> element;       // triangle id or texel index (row * size + column)
  std::vector<uint16_t> frame;         // 0-based frame of the sequence
  std::vector<uint8_t> camera;         // camera index
  std::vector<glm::vec3> reflectance;  // linear RGB
  // Per sample and light: g[i * num_lights() + k], h likewise.
  std::vector<float> g;
  std::vector<float> h;
  // Per sample and light: a_k (see above), or empty: no fall-off (all 1).
  std::vector<float> falloff;

  int num_lights() const { return static_cast<int>(light_names.size()); }
  size_t size() const { return element.size(); }
  // Appends one sample; `g` and `h` hold num_lights() values each, and
  // `falloff_row` too when given (nullptr: a_k = 1; `falloff` stays empty
  // until the first row with fall-off, then earlier samples get 1s).
  void Add(uint32_t element_id, int frame_index, int camera_index, const glm::vec3& rgb, const float* g_row,
           const float* h_row, const float* falloff_row = nullptr);
  // a_k of sample i (1 without fall-off).
  float Falloff(size_t i, int k) const {
    return falloff.empty() ? 1.0f : falloff[i * static_cast<size_t>(num_lights()) + static_cast<size_t>(k)];
  }
  // Mask of the named lights; INVALID_ARGUMENT names an unknown one.
  absl::StatusOr<LightMask> MaskOf(const std::vector<std::string>& names) const;
  // Sum over the lights in `mask` of I_k g_k: the diffuse illumination of
  // sample i per channel.
  glm::vec3 Illumination(size_t i, LightMask mask) const;
  // Bytes held (for reports and cache limits).
  size_t MemoryBytes() const;
};

// Versioned binary encoding (little-endian): a header with magic "MVSS",
// version, counts and light names/intensities, then the arrays; reflectance,
// g, h (and falloff when present) as 16-bit halves when `compact`, else 32-bit
// floats (layout in sample_set.cc). The encoding
// is the cache and wire format (issue #5), so it fails loudly on anything
// unexpected.
std::string EncodeSampleSet(const SampleSet& set, bool compact = true);
// DATA_LOSS naming what is wrong (magic, version, truncation, counts) for a
// corrupt or foreign buffer.
absl::StatusOr<SampleSet> DecodeSampleSet(absl::string_view bytes);

}  // namespace mvbrdf::samples

#endif  // MVBRDF_CORE_SAMPLES_SAMPLE_SET_H_
