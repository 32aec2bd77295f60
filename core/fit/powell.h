// Powell's direction-set method (Numerical Recipes in C, 2nd ed.: §10.5
// powell and linmin, §10.2 brent, §10.1 mnbrak), in double precision and
// without global state. Derivative-free: the thesis's "analysis by
// synthesis" fit (§6.2.3) and NOTES.md ask for this method, not Ceres's
// dogleg.
//
// Differences from the book, all documented where they are made:
//  - Brent's fractional tolerance defaults to 3e-8 (about sqrt(double eps))
//    instead of the float book's 2e-4.
//  - mnbrak gives up after `max_bracket_steps` (the book can loop forever on a
//    function that decreases without bound).
//  - An optional `project` callback maps the point back into the feasible set
//    after each line minimisation. With a cost defined as f(P(x)) for a
//    projection P this leaves the cost unchanged and keeps the iterate from
//    wandering into the flat region outside the bounds.
//  - Running out of iterations is reported in the summary, not an error.
#ifndef MVBRDF_CORE_FIT_POWELL_H_
#define MVBRDF_CORE_FIT_POWELL_H_

#include <functional>

namespace mvbrdf::fit {

struct PowellOptions {
  int max_iterations = 200;           // NR ITMAX of powell
  double function_tolerance = 1e-10;  // NR ftol: relative decrease per iteration to stop
  double line_tolerance = 3e-8;       // NR TOL of linmin (brent's fractional precision)
  int max_brent_iterations = 100;     // NR ITMAX of brent
  int max_bracket_steps = 200;
  // After convergence, start again from the result with fresh unit
  // directions, up to this many times, while a restart still lowers the cost
  // by more than function_tolerance (relative) and the runs so far took fewer
  // than max_iterations iterations in all: Numerical Recipes' advice, as the
  // direction set degenerates and an iteration whose line searches barely
  // move stops the method early.
  int restarts = 0;
};

struct PowellSummary {
  double initial_cost = 0.0;
  double final_cost = 0.0;
  int iterations = 0;            // over every restart
  int function_evaluations = 0;  // likewise
  bool converged = false;        // the last run's relative decrease fell below function_tolerance
};

// Minimises `cost` over x (n values, updated in place) starting from x with
// the unit vectors as directions (again after each of options.restarts). `project`, when set, is applied to x after
// each line minimisation (see above).
PowellSummary MinimizePowell(const std::function<double(const double*)>& cost, int n, double* x,
                             const PowellOptions& options, const std::function<void(double*)>& project = nullptr);

}  // namespace mvbrdf::fit

#endif  // MVBRDF_CORE_FIT_POWELL_H_
