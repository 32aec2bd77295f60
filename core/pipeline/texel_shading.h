// How the texel passes model one observation under a cluster's fitted
// reflectance: r ~ kd G + S per channel (the thesis's Phong: G = sum_k I_k g_k,
// S = ks sum_k I_k a_k h_k^ke; the other models through fit::LobeTerms).
// Shared by pass 2 (reconstruct_stage.cc) and the normal stage, which reads
// the same model at other normals.
#ifndef MVBRDF_CORE_PIPELINE_TEXEL_SHADING_H_
#define MVBRDF_CORE_PIPELINE_TEXEL_SHADING_H_

#include <array>
#include <cmath>
#include <glm/glm.hpp>
#include <vector>

#include "core/brdf/model.h"
#include "core/fit/lobe_fit.h"
#include "core/fit/phong_fit.h"
#include "core/samples/assemble.h"

namespace mvbrdf::pipeline {

// Per channel c: sum of I_k[c] a_k h_k^ke_c over the lights in `mask` (a:
// the fall-off, 1 without fall-off), ln h_k taken once per light for the
// three channels (bit for bit the per-channel sum the texel passes took
// before: texel_shading_test.cc).
inline glm::vec3 SpecularSums(const samples::LightTerms& terms, const std::vector<glm::vec3>& intensity,
                              const samples::LightMask& mask, const fit::PhongRgb& phong) {
  double s[3] = {0.0, 0.0, 0.0};
  for (size_t j = 0; j < terms.count; ++j) {
    const size_t k = terms.light[j];
    if (!mask.Test(k) || !(terms.h[j] > 0.0f)) continue;
    const double log_h = std::log(static_cast<double>(terms.h[j]));
    for (int c = 0; c < 3; ++c) s[c] += intensity[k][c] * terms.falloff[j] * std::exp(phong[c].ke * log_h);
  }
  return glm::vec3(static_cast<float>(s[0]), static_cast<float>(s[1]), static_cast<float>(s[2]));
}

// Sum of I_k g_k over the lights in `mask`.
inline glm::vec3 IlluminationOf(const samples::LightTerms& terms, const std::vector<glm::vec3>& intensity,
                                const samples::LightMask& mask) {
  glm::vec3 s(0.0f);
  for (size_t j = 0; j < terms.count; ++j) {
    if (mask.Test(terms.light[j])) s += intensity[terms.light[j]] * terms.g[j];
  }
  return s;
}

// A cluster's reflectance as the texel passes read it.
struct ClusterShading {
  brdf::Model model = brdf::Model::kPhong;
  fit::PhongRgb phong;                   // Phong's kd, ks, ke
  std::array<fit::LobeChannel, 3> lobe;  // the other models' parameters
};

// G and S of one observation's terms under `cluster` (S in float, ks rounded
// to float first: pass 2's residuals r - S are as they were before this
// function existed, bit for bit). With `phong_sums` (Phong only): the sums
// before ks (SpecularSums), for a caller that scales them in double.
inline void ShadeTexel(const ClusterShading& cluster, const samples::LightTerms& terms,
                       const std::vector<glm::vec3>& intensity, const samples::LightMask& mask, glm::vec3* illumination,
                       glm::vec3* specular, glm::vec3* phong_sums = nullptr) {
  if (cluster.model == brdf::Model::kPhong) {
    *illumination = IlluminationOf(terms, intensity, mask);
    const glm::vec3 sums = SpecularSums(terms, intensity, mask, cluster.phong);
    for (int c = 0; c < 3; ++c) (*specular)[c] = static_cast<float>(cluster.phong[c].ks) * sums[c];
    if (phong_sums != nullptr) *phong_sums = sums;
  } else {
    fit::LobeTerms(cluster.model, cluster.lobe, terms, intensity, mask, specular, illumination);
  }
}

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_TEXEL_SHADING_H_
