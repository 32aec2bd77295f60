// How far towards grazing a capture observed a cluster's GGX lobe (issue
// #15): the support beyond which a fitted microfacet lobe is extrapolated.
//
// GGX's visibility V = 0.5 / s, s = n.l sqrt((n.v)^2 (1 - a^2) + a^2) +
// n.v sqrt((n.l)^2 (1 - a^2) + a^2) (core/brdf/ggx.h), grows as 1 / (2 n.l
// n.v) towards grazing; at the mirror direction the lobe's peak rises without
// bound as 1 / cos^2. Measured materials level off instead: MERL's
// yellow-phenolic's mirror peak is flat past 75 degrees where a fitted GGX
// lobe's is 2x higher at 80 and 15x at 85 (docs/models.md). A capture seldom
// observes those configurations, so its held-out frames and cameras cannot
// tell (auto's judge scores GGX better there), and a relighting under a new
// light and view meets them: on the OLAT sphere one such pixel made auto 1.46x
// Phong's error.
//
// The support: over the terms (Sample, light) that lie inside the fitted lobe
// (D(n.h) >= lobe_fraction D(1), at the lobe's own roughness, of the channel
// with the largest F0), the `quantile` of s. Below it the capture has no
// evidence of the lobe's growth, and the renderer holds s at the support
// (brdf::Ggx::SpecularWithin): the lobe is not extrapolated past what was
// seen. The Samples' cosines alone decide it: no unit of the scene, the lights
// or the images.
#ifndef MVBRDF_CORE_FIT_GRAZING_SUPPORT_H_
#define MVBRDF_CORE_FIT_GRAZING_SUPPORT_H_

#include <array>
#include <cstddef>

#include "core/fit/lobe_fit.h"
#include "core/samples/sample_set.h"

namespace mvbrdf::fit {

struct GrazingSupportOptions {
  // Inside the lobe: D at least this fraction of its peak (the lobe's
  // extent to a tenth: where it still stands out of the diffuse).
  double lobe_fraction = 0.1;
  // Of s over the in-lobe terms: the most grazing percent, so that one
  // stray term does not decide.
  double quantile = 0.01;
  size_t min_terms = 20;       // fewer in-lobe terms: no support (0)
};

struct GrazingSupport {
  double s = 0.0;        // the support (0: none, nothing held)
  size_t in_lobe = 0;    // in-lobe terms it was taken over
};

// `lobe` is the cluster's fitted GGX lobe per channel (p = f0, roughness,
// f90_ratio). The set must carry the half-vector geometry; terms of lights
// the selection leaves out and terms with n.l or n.v <= 0 do not count.
GrazingSupport GgxGrazingSupport(const samples::SampleSet& set, const samples::LightSelection& selection,
                                 const std::array<LobeChannel, 3>& lobe, const GrazingSupportOptions& options = {});

}  // namespace mvbrdf::fit

#endif  // MVBRDF_CORE_FIT_GRAZING_SUPPORT_H_
