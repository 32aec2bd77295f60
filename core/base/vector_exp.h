// exp() over arrays, vectorised (issue #17): the Phong fits spend most of
// their time in exp(ke ln h) over every specular term (perf of
// scripts/bench-peer's fit_peer: glibc's exp 47 % of its samples), one call
// at a time. ExpAffine evaluates a whole array of them with SIMD lanes (GCC
// vector extensions: 2 lanes (SSE2 on baseline x86-64, NEON on arm64), 4 or 8
// where the CPU has them), to within 2 ulp of std::exp (ExpAffineTest).
#ifndef MVBRDF_CORE_BASE_VECTOR_EXP_H_
#define MVBRDF_CORE_BASE_VECTOR_EXP_H_

#include <cstddef>

namespace mvbrdf::base {

// Below this exponent ExpAffine returns exactly 0: std::exp would return at
// most ~3e-308 (a subnormal from ~-708.4, then 0), which no sum of terms of
// order one can hold.
constexpr double kExpFlushBelow = -708.0;

// y[i] = exp(scale * x[i] + offset[i]) (offset may be null: 0), for
// i < n; 0 where the exponent is below kExpFlushBelow (also for -inf x with
// scale > 0, or -inf offset), +inf above ~709.78, NaN for NaN. y may alias x
// or offset.
// Lanes: 8 where the CPU has AVX-512F, 4 where it has AVX2 and FMA, else 2.
void ExpAffine(size_t n, double scale, const double* x, const double* offset, double* y);

// The same with a given lane width (tests: every path the CPU can run);
// false, and nothing written, when the CPU cannot run it (4: AVX2 + FMA, 8:
// AVX-512F) or `lanes` is not 2, 4 or 8.
bool ExpAffineWithLanes(int lanes, size_t n, double scale, const double* x, const double* offset, double* y);

}  // namespace mvbrdf::base

#endif  // MVBRDF_CORE_BASE_VECTOR_EXP_H_
