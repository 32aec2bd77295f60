#include "core/fit/phong_lm.h"

#include <algorithm>
#include <cmath>

namespace mvbrdf::fit::internal {
namespace {

// Cost, J^T J and J^T rho at one point, in one pass.
struct Normal {
  double cost = 0.0;
  double h[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  double g[3] = {0, 0, 0};
};

Normal Evaluate(const PhongChannelData& data, const double* x) {
  // The residuals and Jacobian rows of phong_cost.h, a chunk at a time.
  constexpr size_t kChunk = 1024;
  double rho[kChunk], jacobian[3 * kChunk];
  Normal n;
  double c = 0.0;
  for (size_t begin = 0; begin < data.size(); begin += kChunk) {
    const size_t end = std::min(data.size(), begin + kChunk);
    EvaluatePhongResiduals(data, begin, end, x, rho, jacobian);
    for (size_t i = 0; i < end - begin; ++i) {
      const double* row = jacobian + 3 * i;
      c += rho[i] * rho[i];
      for (int r = 0; r < 3; ++r) {
        n.g[r] += row[r] * rho[i];
        for (int k = r; k < 3; ++k) n.h[r][k] += row[r] * row[k];
      }
    }
  }
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < r; ++k) n.h[r][k] = n.h[k][r];
  }
  n.cost = 0.5 * c;
  return n;
}

// Solves A y = b for the m x m symmetric positive definite A (Cholesky);
// false when it is not.
bool SolveSpd(int m, double a[3][3], double* b) {
  double l[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j <= i; ++j) {
      double sum = a[i][j];
      for (int k = 0; k < j; ++k) sum -= l[i][k] * l[j][k];
      if (i == j) {
        if (!(sum > 0.0)) return false;
        l[i][i] = std::sqrt(sum);
      } else {
        l[i][j] = sum / l[j][j];
      }
    }
  }
  for (int i = 0; i < m; ++i) {
    for (int k = 0; k < i; ++k) b[i] -= l[i][k] * b[k];
    b[i] /= l[i][i];
  }
  for (int i = m - 1; i >= 0; --i) {
    for (int k = i + 1; k < m; ++k) b[i] -= l[k][i] * b[k];
    b[i] /= l[i][i];
  }
  return true;
}

}  // namespace

PhongLmSummary SolvePhongLm(const PhongChannelData& data, const bool* free, const double* lower, const double* upper,
                            const PhongLmOptions& options, double* x) {
  PhongLmSummary summary;
  int index[3], m = 0;
  for (int j = 0; j < 3; ++j) {
    if (free[j]) index[m++] = j;
  }
  Normal at = Evaluate(data, x);
  summary.passes = 1;
  summary.initial_cost = at.cost;
  double mu = 1e-4, nu = 2.0;  // Ceres: 1 / initial trust region radius; its decrease factor
  while (m > 0 && summary.iterations < options.max_iterations) {
    // The projected gradient.
    double projected = 0.0;
    for (int k = 0; k < m; ++k) {
      const int j = index[k];
      projected = std::max(projected, std::abs(x[j] - std::clamp(x[j] - at.g[j], lower[j], upper[j])));
    }
    if (projected <= options.gradient_tolerance) {
      summary.converged = true;
      break;
    }
    // The step over the coordinates not held at a bound by the gradient
    // (one at its bound that the descent pushes outwards stays there; with
    // it in the system, the projection spoilt the others' step and the
    // iteration crawled along the bound).
    int active[3], n = 0;
    for (int k = 0; k < m; ++k) {
      const int j = index[k];
      const bool held = (x[j] <= lower[j] && at.g[j] > 0.0) || (x[j] >= upper[j] && at.g[j] < 0.0);
      if (!held) active[n++] = j;
    }
    double system[3][3], step[3];
    for (int r = 0; r < n; ++r) {
      for (int c = 0; c < n; ++c) system[r][c] = at.h[active[r]][active[c]];
      system[r][r] += mu * std::clamp(at.h[active[r]][active[r]], 1e-6, 1e32);
      step[r] = -at.g[active[r]];
    }
    double trial[3] = {x[0], x[1], x[2]}, delta[3] = {0, 0, 0};
    double step_norm = 0.0, x_norm = 0.0;
    if (n > 0 && SolveSpd(n, system, step)) {
      for (int k = 0; k < n; ++k) {
        const int j = active[k];
        trial[j] = std::clamp(x[j] + step[k], lower[j], upper[j]);
        delta[j] = trial[j] - x[j];
        step_norm += delta[j] * delta[j];
        x_norm += x[j] * x[j];
      }
      if (std::sqrt(step_norm) <= options.parameter_tolerance * (std::sqrt(x_norm) + options.parameter_tolerance)) {
        summary.converged = true;
        break;
      }
    }
    // The model's decrease for the step as taken (after the projection).
    double model = 0.0;
    for (int r = 0; r < 3; ++r) {
      model -= at.g[r] * delta[r];
      for (int c = 0; c < 3; ++c) model -= 0.5 * delta[r] * at.h[r][c] * delta[c];
    }
    ++summary.iterations;
    Normal next;
    bool accepted = false;
    if (model > 0.0) {
      next = Evaluate(data, trial);
      ++summary.passes;
      accepted = std::isfinite(next.cost) && (at.cost - next.cost) > 1e-3 * model;
    }
    if (accepted) {
      const double decrease = at.cost - next.cost, ratio = decrease / model;
      for (int j = 0; j < 3; ++j) x[j] = trial[j];
      const bool small = at.cost <= 0.0 || decrease <= options.function_tolerance * at.cost;
      at = next;
      mu *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * ratio - 1.0, 3));
      nu = 2.0;
      if (small) {
        summary.converged = true;
        break;
      }
    } else {
      mu *= nu;
      nu *= 2.0;
      if (mu > 1e32) {  // Ceres: the trust region below its minimum radius
        summary.converged = true;
        break;
      }
    }
  }
  if (m == 0) summary.converged = true;
  summary.final_cost = at.cost;
  return summary;
}

}  // namespace mvbrdf::fit::internal
