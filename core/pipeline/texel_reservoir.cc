#include "core/pipeline/texel_reservoir.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace mvbrdf::pipeline {
namespace {

// A deterministic hash of (texel, observation number), so that which
// observations are kept does not depend on threads or timing.
uint32_t Hash(uint32_t a, uint32_t b) {
  uint64_t x = (static_cast<uint64_t>(a) << 32) ^ b;
  x ^= x >> 33;
  x *= 0xff51afd7ed558ccdULL;
  x ^= x >> 33;
  x *= 0xc4ceb9fe1a85ec53ULL;
  x ^= x >> 33;
  return static_cast<uint32_t>(x);
}

}  // namespace

TexelReservoir::TexelReservoir(size_t num_texels, int num_lights, int uniform_slots, int highlight_slots, bool falloff,
                               size_t max_terms, bool half_vector)
    : num_lights_(num_lights),
      max_terms_(max_terms > 0 ? std::min(max_terms, static_cast<size_t>(num_lights))
                               : static_cast<size_t>(num_lights)),
      falloff_(falloff),
      half_vector_(half_vector),
      uniform_(uniform_slots),
      highlight_(highlight_slots),
      slots_per_texel_(uniform_slots + highlight_slots),
      row_floats_(3 + (falloff ? 3 : 2) * max_terms_ + (half_vector ? 1 + 2 * max_terms_ : 0)),
      falloff_at_(3 + 2 * max_terms_),
      half_vector_at_(3 + (falloff ? 3 : 2) * max_terms_),
      seen_(num_texels, 0),
      slots_(num_texels * static_cast<size_t>(uniform_slots + highlight_slots)),
      rows_(slots_.size() * row_floats_, 0.0f),
      lights_(slots_.size() * max_terms_, 0) {}

void TexelReservoir::Store(size_t slot, int frame, int camera, float hmax, const glm::vec3& rgb,
                           const samples::LightTerms& terms) {
  // More terms than lights on in a frame cannot happen (FrameStream clears
  // the others); keep the first max_terms_ if it did.
  const size_t count = std::min(terms.count, max_terms_);
  slots_[slot] = {hmax, static_cast<uint16_t>(frame), static_cast<uint8_t>(camera), static_cast<uint16_t>(count)};
  float* row = Row(slot);
  row[0] = rgb.x;
  row[1] = rgb.y;
  row[2] = rgb.z;
  std::memcpy(lights_.data() + slot * max_terms_, terms.light, sizeof(uint16_t) * count);
  std::memcpy(row + 3, terms.g, sizeof(float) * count);
  std::memcpy(row + 3 + max_terms_, terms.h, sizeof(float) * count);
  if (falloff_) {
    for (size_t j = 0; j < count; ++j) row[falloff_at_ + j] = terms.falloff != nullptr ? terms.falloff[j] : 1.0f;
  }
  if (half_vector_) {
    float* hv = row + half_vector_at_;
    hv[0] = terms.n_dot_v;
    if (count > 0 && (terms.n_dot_h == nullptr || terms.v_dot_h == nullptr)) {
      std::fprintf(stderr, "TexelReservoir: an observation without half-vector geometry in a reservoir that keeps it\n");
      std::abort();
    }
    std::memcpy(hv + 1, terms.n_dot_h, sizeof(float) * count);
    std::memcpy(hv + 1 + max_terms_, terms.v_dot_h, sizeof(float) * count);
  }
}

void TexelReservoir::Offer(uint32_t texel, int frame, int camera, const glm::vec3& rgb, const float* g,
                           const float* h, const float* a) {
  std::vector<uint16_t> light;
  std::vector<float> gs, hs, as;
  for (int k = 0; k < num_lights_; ++k) {
    if (!(g[k] > 0.0f)) continue;
    light.push_back(static_cast<uint16_t>(k));
    gs.push_back(g[k]);
    hs.push_back(h[k]);
    as.push_back(a != nullptr ? a[k] : 1.0f);
  }
  samples::LightTerms terms;
  terms.count = light.size();
  terms.light = light.data();
  terms.g = gs.data();
  terms.h = hs.data();
  terms.falloff = as.data();
  Offer(texel, frame, camera, rgb, terms);
}

void TexelReservoir::Offer(uint32_t texel, int frame, int camera, const glm::vec3& rgb,
                           const samples::LightTerms& terms) {
  float hmax = 0.0f;
  for (size_t j = 0; j < terms.count; ++j) hmax = std::max(hmax, terms.h[j]);
  const size_t base = static_cast<size_t>(texel) * static_cast<size_t>(slots_per_texel_);
  const uint32_t n = ++seen_[texel];  // 1-based number of this observation
  if (uniform_ > 0) {
    if (n <= static_cast<uint32_t>(uniform_)) {
      Store(base + n - 1, frame, camera, hmax, rgb, terms);
    } else {
      const uint32_t j = Hash(texel, n) % n;
      if (j < static_cast<uint32_t>(uniform_)) Store(base + j, frame, camera, hmax, rgb, terms);
    }
  }
  if (highlight_ > 0 && hmax > 0.0f) {
    size_t weakest = base + static_cast<size_t>(uniform_);
    for (int s = 1; s < highlight_; ++s) {
      const size_t slot = base + static_cast<size_t>(uniform_ + s);
      if (slots_[slot].hmax < slots_[weakest].hmax) weakest = slot;
    }
    if (hmax > slots_[weakest].hmax) Store(weakest, frame, camera, hmax, rgb, terms);
  }
}

void TexelReservoir::Collect(const std::vector<uint32_t>& texels, size_t max_samples, samples::SampleSet* out) const {
  for (uint32_t texel : texels) {
    if (out->size() >= max_samples) return;
    const size_t base = static_cast<size_t>(texel) * static_cast<size_t>(slots_per_texel_);
    for (int s = 0; s < slots_per_texel_; ++s) {
      const size_t index = base + static_cast<size_t>(s);
      const Slot& slot = slots_[index];
      if (slot.hmax < 0.0f) continue;
      const float* row = Row(index);
      samples::HalfVectorTerms geometry;
      if (half_vector_) {
        const float* hv = row + half_vector_at_;
        geometry = {hv[0], hv + 1, hv + 1 + max_terms_};
      }
      out->AddTerms(texel, slot.frame, slot.camera, {row[0], row[1], row[2]}, slot.count,
                    lights_.data() + index * max_terms_, row + 3, row + 3 + max_terms_,
                    falloff_ ? row + falloff_at_ : nullptr, geometry);
    }
  }
}

size_t TexelReservoir::KeptOf(uint32_t texel) const {
  const size_t base = static_cast<size_t>(texel) * static_cast<size_t>(slots_per_texel_);
  size_t kept = 0;
  for (int s = 0; s < slots_per_texel_; ++s) kept += slots_[base + static_cast<size_t>(s)].hmax >= 0.0f ? 1 : 0;
  return kept;
}

size_t TexelReservoir::MemoryBytes() const {
  return seen_.size() * sizeof(uint32_t) + slots_.size() * sizeof(Slot) + rows_.size() * sizeof(float) +
         lights_.size() * sizeof(uint16_t);
}

}  // namespace mvbrdf::pipeline
