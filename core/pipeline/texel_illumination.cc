#include "core/pipeline/texel_illumination.h"

#include <utility>

#include "absl/strings/str_cat.h"

namespace mvbrdf::pipeline {

size_t TexelIllumination::BytesPerTexel(Layout layout, size_t num_lights, size_t num_masks) {
  return layout == Layout::kPerLight ? num_lights * sizeof(float) : num_masks * sizeof(glm::dvec3);
}

TexelIllumination::Layout TexelIllumination::ChooseLayout(size_t num_lights, size_t num_masks) {
  return BytesPerTexel(Layout::kPerConfiguration, num_lights, num_masks) <
                 BytesPerTexel(Layout::kPerLight, num_lights, num_masks)
             ? Layout::kPerConfiguration
             : Layout::kPerLight;
}

TexelIllumination::TexelIllumination(size_t num_texels, std::vector<glm::vec3> intensity,
                                     std::vector<samples::LightMask> masks)
    : TexelIllumination(num_texels, intensity, masks, ChooseLayout(intensity.size(), masks.size())) {}

TexelIllumination::TexelIllumination(size_t num_texels, std::vector<glm::vec3> intensity,
                                     std::vector<samples::LightMask> masks, Layout layout)
    : layout_(layout),
      num_texels_(num_texels),
      num_lights_(intensity.size()),
      intensity_(std::move(intensity)),
      masks_(std::move(masks)) {
  if (layout_ == Layout::kPerLight) {
    per_light_.assign(num_texels * num_lights_, 0.0f);
    return;
  }
  per_mask_.assign(num_texels * masks_.size(), glm::dvec3(0.0));
  masks_of_light_.resize(num_lights_);
  for (size_t m = 0; m < masks_.size(); ++m) {
    masks_[m].ForEach([&](size_t k) {
      if (k < num_lights_) masks_of_light_[k].push_back(static_cast<uint32_t>(m));
    });
  }
}

void TexelIllumination::Add(uint32_t texel, const samples::LightTerms& terms, bool own) {
  if (own) {
    if (own_.empty()) own_.assign(num_texels_, glm::dvec3(0.0));
    for (size_t j = 0; j < terms.count; ++j) {
      own_[texel] += glm::dvec3(intensity_[terms.light[j]]) * static_cast<double>(terms.g[j]);
    }
    return;
  }
  if (layout_ == Layout::kPerLight) {
    float* gs = per_light_.data() + static_cast<size_t>(texel) * num_lights_;
    for (size_t j = 0; j < terms.count; ++j) gs[terms.light[j]] += terms.g[j];
    return;
  }
  glm::dvec3* sums = per_mask_.data() + static_cast<size_t>(texel) * masks_.size();
  for (size_t j = 0; j < terms.count; ++j) {
    const glm::dvec3 ig = glm::dvec3(intensity_[terms.light[j]]) * static_cast<double>(terms.g[j]);
    for (uint32_t m : masks_of_light_[terms.light[j]]) sums[m] += ig;
  }
}

absl::StatusOr<glm::dvec3> TexelIllumination::Of(uint32_t texel, const samples::LightMask& mask) const {
  const glm::dvec3 own = own_.empty() ? glm::dvec3(0.0) : own_[texel];
  if (layout_ == Layout::kPerLight) {
    glm::dvec3 illumination = own;
    const float* gs = per_light_.data() + static_cast<size_t>(texel) * num_lights_;
    for (size_t k = 0; k < num_lights_; ++k) {
      if (mask.Test(k)) illumination += glm::dvec3(intensity_[k]) * static_cast<double>(gs[k]);
    }
    return illumination;
  }
  for (size_t m = 0; m < masks_.size(); ++m) {
    if (masks_[m] == mask) return own + per_mask_[static_cast<size_t>(texel) * masks_.size() + m];
  }
  return absl::InternalError(absl::StrCat("texel illumination: light set ", mask.ToString(),
                                          " was not gathered (the pass kept ", masks_.size(), " configurations)"));
}

}  // namespace mvbrdf::pipeline
