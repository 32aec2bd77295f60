// Samples generated directly from known Phong parameters for the fitting
// tests (no rendering): random unit normals, light and view directions, g
// and h per shared/NOTES.md, and r from the model evaluated on the stored
// (float) g and h, so that noise-free data is exactly representable.
#ifndef MVBRDF_CORE_FIT_FIT_TEST_UTIL_H_
#define MVBRDF_CORE_FIT_FIT_TEST_UTIL_H_

#include <cstdint>
#include <glm/glm.hpp>
#include <string>
#include <vector>

#include "core/fit/lobe_fit.h"
#include "core/fit/phong_fit.h"
#include "core/samples/sample_set.h"

namespace mvbrdf::fit::testing {

struct GeneratorOptions {
  size_t num_samples = 4000;
  int num_lights = 4;
  // Lights that produce the reflectance (all when 0); the set holds all.
  samples::LightMask true_mask;
  glm::vec3 intensity{1.0f};  // every light's intensity
  uint32_t num_elements = 1;  // element = sample % num_elements
  // Fraction of samples viewed close to the mirror direction of one of their
  // lights, at an angle drawn from |N(0, spread)|; spread 0 means
  // 1.5 / sqrt(max ke) so that the lobe is sampled whatever its width.
  double highlight_fraction = 0.5;
  double highlight_spread = 0.0;
  // When set, no sample has h above this (views rejected until none does).
  double max_highlight = 1.0;
  // Lights drawn with l.n in (0, max_light_cosine] and views with n.v in
  // (0, max_view_cosine] when below 1 (grazing); lights are else in the
  // upper hemisphere with probability 0.85 and anywhere otherwise.
  double max_light_cosine = 1.0;
  double max_view_cosine = 1.0;
  // Additive Gaussian noise, sigma = noise * the mean reflectance per channel.
  double noise = 0.0;
  // Reflectances clipped to [0, clip] when > 0 (saturated video).
  double clip = 0.0;
  uint64_t seed = 1;
};

// `kd_of_element` (optional, num_elements values) replaces truth's kd per element.
samples::SampleSet MakeSamples(const PhongRgb& truth, const GeneratorOptions& options,
                               const std::vector<glm::vec3>& kd_of_element = {});

// Issue #13: `num_lights` candidate lights (intensities differ per light and
// channel), each sample lit by `lights_on` of them (1: OLAT; the lights of
// sample i are i, i + s, ... mod num_lights for a stride s), so a sample holds
// only those terms. Half of the samples view the first light's mirror
// direction closely (highlights for ks and ke). Reflectance from `truth`,
// element = sample % num_elements, kd per element when `kd_of_element`.
samples::SampleSet MakeManyLightSamples(const PhongRgb& truth, int num_lights, int lights_on, size_t num_samples,
                                        uint32_t num_elements = 1, const std::vector<glm::vec3>& kd_of_element = {},
                                        uint64_t seed = 1);

// The model on sample i of `set` for `mask` with the given parameters (double).
glm::dvec3 ModelValue(const samples::SampleSet& set, size_t i, const samples::LightMask& mask, const PhongRgb& p,
                      const glm::vec3& kd);

PhongRgb MakePhong(const glm::dvec3& kd, const glm::dvec3& ks, const glm::dvec3& ke);

std::string ToString(const PhongRgb& p);

// Issue #15: any model of core/brdf, per channel.
struct LobeTruth {
  BrdfModel model;
  std::array<LobeChannel, 3> params;
};

// Samples of a surface point (n = +z) seen from random views under 4 of 6
// lights, half of them placed near the mirror direction of the view so that
// every model's lobe is observed; rendered with `truth` (core/brdf's models,
// the fit's own equation) and relative noise `noise`.
// With `texels` > 0 the samples belong to that many texels (element i mod
// texels, frames i / texels) whose kd varies by +- `texture` (relative).
// Sample i is from camera i % 4.
samples::SampleSet RenderLobeSamples(const LobeTruth& truth, int num_samples, double noise, uint32_t seed,
                                     double intensity_scale = 1.0, int texels = 0, double texture = 0.0);

}  // namespace mvbrdf::fit::testing

#endif  // MVBRDF_CORE_FIT_FIT_TEST_UTIL_H_
