#include "core/fit/powell.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace mvbrdf::fit {
namespace {

constexpr double kGold = 1.618034;    // NR mnbrak GOLD
constexpr double kGLimit = 100.0;     // NR mnbrak GLIMIT
constexpr double kTiny = 1.0e-20;     // NR mnbrak and powell TINY
constexpr double kCGold = 0.3819660;  // NR brent CGOLD
constexpr double kZeps = 1.0e-10;     // NR brent ZEPS (absolute tolerance near 0)

double Sign(double a, double b) { return b >= 0.0 ? std::fabs(a) : -std::fabs(a); }

// The one-dimensional function f(s) = cost(p + s xi) of linmin (NR f1dim).
class LineFunction {
 public:
  LineFunction(const std::function<double(const double*)>& cost, const std::vector<double>& p,
               const std::vector<double>& xi, int* evaluations)
      : cost_(cost), p_(p), xi_(xi), point_(p.size()), evaluations_(evaluations) {}

  double operator()(double s) {
    for (size_t j = 0; j < p_.size(); ++j) point_[j] = p_[j] + s * xi_[j];
    ++*evaluations_;
    return cost_(point_.data());
  }

 private:
  const std::function<double(const double*)>& cost_;
  const std::vector<double>& p_;
  const std::vector<double>& xi_;
  std::vector<double> point_;
  int* evaluations_;
};

// NR §10.1 mnbrak: from a and b, a bracket a < b < c (or reversed) with
// f(b) <= f(a), f(c).
void Bracket(LineFunction& f, double* ax, double* bx, double* cx, double* fa, double* fb, double* fc, int max_steps) {
  *fa = f(*ax);
  *fb = f(*bx);
  if (*fb > *fa) {
    std::swap(*ax, *bx);
    std::swap(*fa, *fb);
  }
  *cx = *bx + kGold * (*bx - *ax);
  *fc = f(*cx);
  for (int step = 0; *fb > *fc && step < max_steps; ++step) {
    const double r = (*bx - *ax) * (*fb - *fc);
    const double q = (*bx - *cx) * (*fb - *fa);
    double u = *bx - ((*bx - *cx) * q - (*bx - *ax) * r) / (2.0 * Sign(std::max(std::fabs(q - r), kTiny), q - r));
    const double ulim = *bx + kGLimit * (*cx - *bx);
    double fu;
    if ((*bx - u) * (u - *cx) > 0.0) {  // parabolic u between b and c
      fu = f(u);
      if (fu < *fc) {  // minimum between b and c
        *ax = *bx;
        *bx = u;
        *fa = *fb;
        *fb = fu;
        return;
      } else if (fu > *fb) {  // minimum between a and u
        *cx = u;
        *fc = fu;
        return;
      }
      u = *cx + kGold * (*cx - *bx);
      fu = f(u);
    } else if ((*cx - u) * (u - ulim) > 0.0) {  // parabolic u between c and its limit
      fu = f(u);
      if (fu < *fc) {
        *bx = *cx;
        *cx = u;
        u = *cx + kGold * (*cx - *bx);
        *fb = *fc;
        *fc = fu;
        fu = f(u);
      }
    } else if ((u - ulim) * (ulim - *cx) >= 0.0) {  // limit parabolic u to its maximum
      u = ulim;
      fu = f(u);
    } else {  // reject parabolic u, default magnification
      u = *cx + kGold * (*cx - *bx);
      fu = f(u);
    }
    *ax = *bx;
    *bx = *cx;
    *cx = u;
    *fa = *fb;
    *fb = *fc;
    *fc = fu;
  }
}

// NR §10.2 brent: the minimum of f in the bracket (ax, bx, cx), f(bx) = fbx
// known. Returns f at the minimum, its abscissa in *xmin.
double Brent(LineFunction& f, double ax, double bx, double cx, double fbx, double tol, int max_iterations,
             double* xmin) {
  double a = std::min(ax, cx), b = std::max(ax, cx);
  double x = bx, w = bx, v = bx;
  double fx = fbx, fw = fbx, fv = fbx;
  double d = 0.0, e = 0.0;
  for (int iter = 0; iter < max_iterations; ++iter) {
    const double xm = 0.5 * (a + b);
    const double tol1 = tol * std::fabs(x) + kZeps;
    const double tol2 = 2.0 * tol1;
    if (std::fabs(x - xm) <= (tol2 - 0.5 * (b - a))) break;
    if (std::fabs(e) > tol1) {  // trial parabolic fit
      const double r = (x - w) * (fx - fv);
      double q = (x - v) * (fx - fw);
      double p = (x - v) * q - (x - w) * r;
      q = 2.0 * (q - r);
      if (q > 0.0) p = -p;
      q = std::fabs(q);
      const double etemp = e;
      e = d;
      if (std::fabs(p) >= std::fabs(0.5 * q * etemp) || p <= q * (a - x) || p >= q * (b - x)) {
        e = (x >= xm ? a - x : b - x);
        d = kCGold * e;  // golden section
      } else {
        d = p / q;  // parabolic step
        const double u = x + d;
        if (u - a < tol2 || b - u < tol2) d = Sign(tol1, xm - x);
      }
    } else {
      e = (x >= xm ? a - x : b - x);
      d = kCGold * e;
    }
    const double u = (std::fabs(d) >= tol1 ? x + d : x + Sign(tol1, d));
    const double fu = f(u);
    if (fu <= fx) {
      if (u >= x) {
        a = x;
      } else {
        b = x;
      }
      v = w;
      w = x;
      x = u;
      fv = fw;
      fw = fx;
      fx = fu;
    } else {
      if (u < x) {
        a = u;
      } else {
        b = u;
      }
      if (fu <= fw || w == x) {
        v = w;
        w = u;
        fv = fw;
        fw = fu;
      } else if (fu <= fv || v == x || v == w) {
        v = u;
        fv = fu;
      }
    }
  }
  *xmin = x;
  return fx;
}

// NR §10.5 linmin: moves p to the minimum along xi, replaces xi by the
// actual displacement, returns the cost there.
double LineMinimize(const std::function<double(const double*)>& cost, std::vector<double>& p, std::vector<double>& xi,
                    double fp, const PowellOptions& options, int* evaluations) {
  LineFunction f(cost, p, xi, evaluations);
  double ax = 0.0, xx = 1.0, bx, fa, fx, fb;
  Bracket(f, &ax, &xx, &bx, &fa, &fx, &fb, options.max_bracket_steps);
  double xmin = 0.0;
  double fmin = Brent(f, ax, xx, bx, fx, options.line_tolerance, options.max_brent_iterations, &xmin);
  // The line function was evaluated at s = 0 (fa or fx) with the value fp
  // known by the caller; never return a worse point than the start.
  if (!(fmin <= fp)) {
    xmin = 0.0;
    fmin = fp;
  }
  for (size_t j = 0; j < p.size(); ++j) {
    xi[j] *= xmin;
    p[j] += xi[j];
  }
  return fmin;
}

}  // namespace

namespace {

// One run of the method from x with the unit directions.
PowellSummary MinimizePowellOnce(const std::function<double(const double*)>& cost, int n, double* x,
                                 const PowellOptions& options, const std::function<void(double*)>& project) {
  PowellSummary summary;
  const size_t size = static_cast<size_t>(n);
  std::vector<double> p(x, x + size), pt = p, ptt(size), xit(size);
  // Direction set: column i of the book's xi is directions[i].
  std::vector<std::vector<double>> directions(size, std::vector<double>(size, 0.0));
  for (size_t i = 0; i < size; ++i) directions[i][i] = 1.0;

  auto evaluate = [&](const std::vector<double>& point) {
    ++summary.function_evaluations;
    return cost(point.data());
  };
  auto line_minimize = [&](std::vector<double>& direction, double f_start) {
    const double f = LineMinimize(cost, p, direction, f_start, options, &summary.function_evaluations);
    if (project) project(p.data());
    return f;
  };

  double fret = evaluate(p);
  summary.initial_cost = fret;
  for (summary.iterations = 1;; ++summary.iterations) {
    const double fp = fret;
    size_t ibig = 0;
    double del = 0.0;  // largest decrease along one direction
    for (size_t i = 0; i < size; ++i) {
      xit = directions[i];
      const double fptt = fret;
      fret = line_minimize(xit, fret);
      if (fptt - fret > del) {
        del = fptt - fret;
        ibig = i;
      }
    }
    if (2.0 * (fp - fret) <= options.function_tolerance * (std::fabs(fp) + std::fabs(fret)) + kTiny) {
      summary.converged = true;
      break;
    }
    if (summary.iterations >= options.max_iterations) break;
    for (size_t j = 0; j < size; ++j) {
      ptt[j] = 2.0 * p[j] - pt[j];  // extrapolated point
      xit[j] = p[j] - pt[j];        // average direction moved
      pt[j] = p[j];
    }
    if (project) project(ptt.data());
    const double fptt = evaluate(ptt);
    if (fptt < fp) {
      const double t =
          2.0 * (fp - 2.0 * fret + fptt) * (fp - fret - del) * (fp - fret - del) - del * (fp - fptt) * (fp - fptt);
      if (t < 0.0) {
        fret = line_minimize(xit, fret);
        directions[ibig] = directions[size - 1];
        directions[size - 1] = xit;
      }
    }
  }
  summary.final_cost = fret;
  std::copy(p.begin(), p.end(), x);
  return summary;
}

}  // namespace

PowellSummary MinimizePowell(const std::function<double(const double*)>& cost, int n, double* x,
                             const PowellOptions& options, const std::function<void(double*)>& project) {
  PowellSummary summary = MinimizePowellOnce(cost, n, x, options, project);
  for (int restart = 0; restart < options.restarts && summary.converged && summary.iterations < options.max_iterations;
       ++restart) {
    const PowellSummary again = MinimizePowellOnce(cost, n, x, options, project);
    const double before = summary.final_cost;
    summary.iterations += again.iterations;
    summary.function_evaluations += again.function_evaluations;
    summary.final_cost = again.final_cost;
    summary.converged = again.converged;
    if (!(before - again.final_cost > options.function_tolerance * std::fabs(before))) break;
  }
  return summary;
}

}  // namespace mvbrdf::fit
