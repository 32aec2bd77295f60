// A fused Levenberg-Marquardt solver for one channel of the Phong fit
// (phong_cost.h's normalised cost in x = (a, b, t)), issue #17.
//
// Ceres solved this 3-parameter problem with ~50 residual and Jacobian passes
// and per-iteration bookkeeping that dominates (PERF.md; scripts/bench-peer:
// no faster than SciPy). Here one pass over the samples evaluates the cost,
// J^T J (3 x 3) and J^T rho together at a trial point: a step costs one pass,
// its acceptance needs no second one, and nothing but three sums per sample
// is stored.
//
// The method is Ceres's LM as FitPhong configured it: the damped normal
// equations (J^T J + mu D) delta = -J^T rho with D = diag(J^T J) (clamped to
// [1e-6, 1e32]), mu = 1e-4 at the start (Ceres's initial trust region radius
// 1e4), the step projected onto the box bounds, accepted when the cost's
// actual decrease is at least 1e-3 of the model's; mu then shrinks by
// max(1/3, 1 - (2 rho - 1)^3), else grows by nu (doubling). Unlike Ceres, a
// coordinate at a bound that the gradient pushes outwards is left out of the
// step (an active set). Stops when the
// relative cost decrease of an accepted step is below function_tolerance,
// the step below parameter_tolerance relative to x, the projected gradient's
// largest entry below gradient_tolerance, or after max_iterations steps.
// Coordinates with free[j] false are held.
#ifndef MVBRDF_CORE_FIT_PHONG_LM_H_
#define MVBRDF_CORE_FIT_PHONG_LM_H_

#include "core/fit/phong_cost.h"

namespace mvbrdf::fit::internal {

struct PhongLmOptions {
  int max_iterations = 100;
  double function_tolerance = 1e-10;
  double parameter_tolerance = 1e-10;
  double gradient_tolerance = 1e-10;
};

struct PhongLmSummary {
  int iterations = 0;         // steps tried (accepted or not)
  int passes = 0;             // passes over the samples
  bool converged = false;     // a tolerance was met (not the iteration limit)
  double initial_cost = 0.0;  // C at the start (the first pass's sums, as PhongCost takes them)
  double final_cost = 0.0;    // phong_cost.h's C(x), normalised units, at the result
};

// Minimises C over the free coordinates of x within [lower, upper]; x must
// start inside the box.
PhongLmSummary SolvePhongLm(const PhongChannelData& data, const bool* free, const double* lower, const double* upper,
                            const PhongLmOptions& options, double* x);

}  // namespace mvbrdf::fit::internal

#endif  // MVBRDF_CORE_FIT_PHONG_LM_H_
