// The guarded per-light terms of the Phong model, shared by the fitter, the
// diffuse solve and EvaluateSample, so that all three treat odd inputs alike
// (shared/NOTES.md: g = max(0, l.n), h = max(0, R(l).v), h = 0 where g = 0).
//
//   cosine:    g' = g        if g is finite and > 0, else 0
//   highlight: h' = min(h,1) if g' > 0 and h is finite and > 0, else 0
//   power:     h'^ke = exp(ke * ln h')   for h' in (0, 1]   (0 for h' = 0)
//
// exp(ke ln h) never overflows for h <= 1 and underflows cleanly to 0 for a
// huge ke; pow(0, ke) and ln(0) are never evaluated.
#ifndef MVBRDF_CORE_FIT_PHONG_TERMS_H_
#define MVBRDF_CORE_FIT_PHONG_TERMS_H_

#include <cmath>

namespace mvbrdf::fit::internal {

inline double ClampedCosine(float g) { return std::isfinite(g) && g > 0.0f ? static_cast<double>(g) : 0.0; }

// `g` already clamped by ClampedCosine.
inline double ClampedHighlight(double g, float h) {
  if (!(g > 0.0) || !std::isfinite(h) || !(h > 0.0f)) return 0.0;
  return h >= 1.0f ? 1.0 : static_cast<double>(h);
}

// Several exponents of one h (the three channels' ke): ln h once
// (LogHighlight), then SpecularPowerOfLog per exponent, equal bit for bit
// to SpecularPower(h, ke).
inline double LogHighlight(double h) { return h > 0.0 && h < 1.0 ? std::log(h) : 0.0; }
inline double SpecularPowerOfLog(double h, double log_h, double ke) {
  if (!(h > 0.0)) return 0.0;
  if (h >= 1.0) return 1.0;
  return std::exp(ke * log_h);
}

// h^ke for a clamped highlight cosine h in [0, 1] and ke > 0.
inline double SpecularPower(double h, double ke) { return SpecularPowerOfLog(h, LogHighlight(h), ke); }

}  // namespace mvbrdf::fit::internal

#endif  // MVBRDF_CORE_FIT_PHONG_TERMS_H_
