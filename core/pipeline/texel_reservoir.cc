#include "core/pipeline/texel_reservoir.h"

#include <algorithm>
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

TexelReservoir::TexelReservoir(size_t num_texels, int num_lights, int uniform_slots, int highlight_slots,
                               bool falloff)
    : num_lights_(num_lights),
      falloff_(falloff),
      uniform_(uniform_slots),
      highlight_(highlight_slots),
      slots_per_texel_(uniform_slots + highlight_slots),
      row_floats_(3 + (falloff ? 3 : 2) * static_cast<size_t>(num_lights)),
      seen_(num_texels, 0),
      slots_(num_texels * static_cast<size_t>(uniform_slots + highlight_slots)),
      rows_(slots_.size() * row_floats_, 0.0f) {}

void TexelReservoir::Store(size_t slot, int frame, int camera, float hmax, const glm::vec3& rgb, const float* g,
                           const float* h, const float* a) {
  slots_[slot] = {hmax, static_cast<uint16_t>(frame), static_cast<uint8_t>(camera)};
  float* row = Row(slot);
  row[0] = rgb.x;
  row[1] = rgb.y;
  row[2] = rgb.z;
  std::memcpy(row + 3, g, sizeof(float) * static_cast<size_t>(num_lights_));
  std::memcpy(row + 3 + num_lights_, h, sizeof(float) * static_cast<size_t>(num_lights_));
  if (falloff_) {
    for (int k = 0; k < num_lights_; ++k) row[3 + 2 * num_lights_ + k] = a != nullptr ? a[k] : 1.0f;
  }
}

void TexelReservoir::Offer(uint32_t texel, int frame, int camera, const glm::vec3& rgb, const float* g,
                           const float* h, const float* a) {
  float hmax = 0.0f;
  for (int k = 0; k < num_lights_; ++k) hmax = std::max(hmax, h[k]);
  const size_t base = static_cast<size_t>(texel) * static_cast<size_t>(slots_per_texel_);
  const uint32_t n = ++seen_[texel];  // 1-based number of this observation
  if (uniform_ > 0) {
    if (n <= static_cast<uint32_t>(uniform_)) {
      Store(base + n - 1, frame, camera, hmax, rgb, g, h, a);
    } else {
      const uint32_t j = Hash(texel, n) % n;
      if (j < static_cast<uint32_t>(uniform_)) Store(base + j, frame, camera, hmax, rgb, g, h, a);
    }
  }
  if (highlight_ > 0 && hmax > 0.0f) {
    size_t weakest = base + static_cast<size_t>(uniform_);
    for (int s = 1; s < highlight_; ++s) {
      const size_t slot = base + static_cast<size_t>(uniform_ + s);
      if (slots_[slot].hmax < slots_[weakest].hmax) weakest = slot;
    }
    if (hmax > slots_[weakest].hmax) Store(weakest, frame, camera, hmax, rgb, g, h, a);
  }
}

void TexelReservoir::Collect(const std::vector<uint32_t>& texels, size_t max_samples, samples::SampleSet* out) const {
  for (uint32_t texel : texels) {
    if (out->size() >= max_samples) return;
    const size_t base = static_cast<size_t>(texel) * static_cast<size_t>(slots_per_texel_);
    for (int s = 0; s < slots_per_texel_; ++s) {
      const Slot& slot = slots_[base + static_cast<size_t>(s)];
      if (slot.hmax < 0.0f) continue;
      const float* row = Row(base + static_cast<size_t>(s));
      out->Add(texel, slot.frame, slot.camera, {row[0], row[1], row[2]}, row + 3, row + 3 + num_lights_,
               falloff_ ? row + 3 + 2 * num_lights_ : nullptr);
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
  return seen_.size() * sizeof(uint32_t) + slots_.size() * sizeof(Slot) + rows_.size() * sizeof(float);
}

}  // namespace mvbrdf::pipeline
