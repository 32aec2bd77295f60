// A few Samples kept per texel during the gathering pass, for fitting one
// BRDF per cluster once the clusters are known (the clusters come from every
// texel's mean, which needs the whole pass first).
//
// Per texel: `uniform` slots by reservoir sampling (every observation equally
// likely to be kept) and `highlight` slots holding the observations with the
// largest highlight cosine max_k h_k. Choosing samples by the regressors (the
// cosines) and never by the response (the reflectance) keeps least squares
// unbiased, and the highlight slots make sure ks and ke see highlights, which
// are rare per texel. Memory: slots x texels x (3 + 2M floats + M u16), M
// the most lights a Sample can hold (those on in one frame; an OLAT capture
// has M = 1 whatever the candidate count).
#ifndef MVBRDF_CORE_PIPELINE_TEXEL_RESERVOIR_H_
#define MVBRDF_CORE_PIPELINE_TEXEL_RESERVOIR_H_

#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "core/samples/assemble.h"
#include "core/samples/sample_set.h"

namespace mvbrdf::pipeline {

class TexelReservoir {
 public:
  // `falloff`: also keep the per-light fall-off a_k of each sample (scenes
  // with inverse-square fall-off; SampleSet::falloff).
  // `max_terms`: the most terms an observation has (0: num_lights).
  // `half_vector`: also keep the half-vector geometry (n.v, and n.h, v.h per
  // term; SampleSet::half_vector), for the models other than Phong.
  TexelReservoir(size_t num_texels, int num_lights, int uniform_slots, int highlight_slots, bool falloff = false,
                 size_t max_terms = 0, bool half_vector = false);

  // One observation of `texel`: its terms (at most max_terms; a is ignored
  // without fall-off).
  void Offer(uint32_t texel, int frame, int camera, const glm::vec3& rgb, const samples::LightTerms& terms);
  // The same from dense rows (g, h and a hold num_lights values; a reservoir
  // without half-vector geometry).
  void Offer(uint32_t texel, int frame, int camera, const glm::vec3& rgb, const float* g, const float* h,
             const float* a = nullptr);

  // The kept Samples of the given texels (element = texel index), appended
  // to `out` (whose lights must match, and which stores the half-vector
  // geometry only if this reservoir keeps it), at most `max_samples` (texels taken
  // in the given order, all slots of a texel together).
  void Collect(const std::vector<uint32_t>& texels, size_t max_samples, samples::SampleSet* out) const;

  // Samples kept for `texel` (at most uniform + highlight slots).
  size_t KeptOf(uint32_t texel) const;
  size_t MemoryBytes() const;

 private:
  struct Slot {
    float hmax = -1.0f;  // < 0: empty
    uint16_t frame = 0;
    uint8_t camera = 0;
    uint16_t count = 0;  // terms
  };
  float* Row(size_t slot) { return rows_.data() + slot * row_floats_; }
  const float* Row(size_t slot) const { return rows_.data() + slot * row_floats_; }
  void Store(size_t slot, int frame, int camera, float hmax, const glm::vec3& rgb, const samples::LightTerms& terms);

  int num_lights_;
  size_t max_terms_;
  bool falloff_;
  bool half_vector_;
  int uniform_, highlight_, slots_per_texel_;
  // Per slot's row: rgb, g[M], h[M], (a[M]), (n.v, n.h[M], v.h[M]).
  size_t row_floats_;
  size_t falloff_at_, half_vector_at_;
  std::vector<uint32_t> seen_;  // observations offered per texel
  std::vector<Slot> slots_;
  std::vector<float> rows_;
  std::vector<uint16_t> lights_;  // per slot: light[M]
};

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_TEXEL_RESERVOIR_H_
