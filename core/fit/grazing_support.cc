#include "core/fit/grazing_support.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/brdf/geometry.h"
#include "core/brdf/ggx.h"

namespace mvbrdf::fit {

GrazingSupport GgxGrazingSupport(const samples::SampleSet& set, const samples::LightSelection& selection,
                                 const std::array<LobeChannel, 3>& lobe, const GrazingSupportOptions& options) {
  GrazingSupport support;
  if (!set.half_vector) return support;
  int dominant = 0;
  for (int c = 1; c < 3; ++c) {
    if (lobe[static_cast<size_t>(c)].p[0] > lobe[static_cast<size_t>(dominant)].p[0]) dominant = c;
  }
  const double roughness = lobe[static_cast<size_t>(dominant)].p[1];
  const double a2 = std::pow(roughness, 4.0);  // (roughness^2)^2
  // D(c) / D(1) = a^4 / q^2 with q = c^2 (a^2 - 1) + 1: inside the lobe
  // where q <= a^2 / sqrt(lobe_fraction).
  const double q_max = a2 / std::sqrt(options.lobe_fraction);
  std::vector<double> s;
  for (size_t i = 0; i < set.size(); ++i) {
    for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) {
      if (!selection.Selects(set.frame[i], set.light[j])) continue;
      const brdf::Geometry g = TermGeometry(set, i, j);
      if (!(g.n_dot_l > 0.0) || !(g.n_dot_v > 0.0)) continue;
      const double c = std::clamp(g.n_dot_h, 0.0, 1.0);
      if (c * c * (a2 - 1.0) + 1.0 > q_max) continue;
      s.push_back(brdf::Ggx::VisibilityDenominator(roughness, g));
    }
  }
  support.in_lobe = s.size();
  if (s.size() < options.min_terms) return support;
  const size_t k = std::min(s.size() - 1, static_cast<size_t>(options.quantile * static_cast<double>(s.size())));
  std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(k), s.end());
  support.s = s[k];
  return support;
}

}  // namespace mvbrdf::fit
