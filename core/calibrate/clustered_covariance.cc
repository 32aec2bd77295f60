#include "core/calibrate/clustered_covariance.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "absl/strings/str_cat.h"

namespace mvbrdf::calibrate {
namespace {

// Row-major dense matrices as plain vectors (see the header on Eigen).
using Dense = std::vector<double>;

// The pseudo-inverse of the symmetric positive semi-definite n x n `a`
// (cyclic Jacobi rotations; eigenvalues below `relative` of the largest are
// taken as 0); `rank` gets how many were kept.
Dense PseudoInverse(int n, Dense a, double relative, int* rank = nullptr) {
  Dense v(static_cast<size_t>(n * n), 0.0);
  for (int i = 0; i < n; ++i) v[static_cast<size_t>(i * n + i)] = 1.0;
  const auto at = [n](Dense& m, int i, int j) -> double& { return m[static_cast<size_t>(i * n + j)]; };
  for (int sweep = 0; sweep < 100; ++sweep) {
    double off = 0.0, diag = 0.0;
    for (int i = 0; i < n; ++i) {
      diag += at(a, i, i) * at(a, i, i);
      for (int j = i + 1; j < n; ++j) off += at(a, i, j) * at(a, i, j);
    }
    if (off <= 1e-30 * diag || off == 0.0) break;
    for (int p = 0; p < n; ++p) {
      for (int q = p + 1; q < n; ++q) {
        const double apq = at(a, p, q);
        if (apq == 0.0) continue;
        const double theta = (at(a, q, q) - at(a, p, p)) / (2.0 * apq);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
        for (int k = 0; k < n; ++k) {  // a <- a J (columns p, q)
          const double akp = at(a, k, p), akq = at(a, k, q);
          at(a, k, p) = c * akp - s * akq;
          at(a, k, q) = s * akp + c * akq;
        }
        for (int k = 0; k < n; ++k) {  // a <- J^T a (rows p, q)
          const double apk = at(a, p, k), aqk = at(a, q, k);
          at(a, p, k) = c * apk - s * aqk;
          at(a, q, k) = s * apk + c * aqk;
        }
        for (int k = 0; k < n; ++k) {  // v <- v J
          const double vkp = at(v, k, p), vkq = at(v, k, q);
          at(v, k, p) = c * vkp - s * vkq;
          at(v, k, q) = s * vkp + c * vkq;
        }
      }
    }
  }
  double largest = 0.0;
  for (int i = 0; i < n; ++i) largest = std::max(largest, at(a, i, i));
  Dense out(static_cast<size_t>(n * n), 0.0);
  int kept = 0;
  for (int k = 0; k < n; ++k) {
    const double lambda = at(a, k, k);
    if (!(largest > 0.0) || !(lambda > relative * largest)) continue;
    ++kept;
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) at(out, i, j) += at(v, i, k) * at(v, j, k) / lambda;
    }
  }
  if (rank != nullptr) *rank = kept;
  return out;
}

}  // namespace

absl::StatusOr<ClusteredCovarianceResult> ClusteredCovariance(ceres::Problem& problem, const std::vector<double*>& interest,
                                                    const std::vector<std::vector<ceres::ResidualBlockId>>& clusters) {
  // Columns of interest: the tangent spaces of the variable blocks, stacked.
  ClusteredCovarianceResult out;
  std::map<const double*, int> interest_column;
  int m = 0;
  for (double* block : interest) {
    if (!problem.HasParameterBlock(block) || problem.IsParameterBlockConstant(block)) {
      out.offset.push_back(-1);
      continue;
    }
    out.offset.push_back(m);
    interest_column[block] = m;
    m += problem.ParameterBlockTangentSize(block);
  }
  if (m == 0) return out;

  // Per cluster only its Gram sums are needed: with A its nuisance columns,
  // B the columns of interest and P = A (A^T A)^+ A^T,
  //   B~^T B~ = B^T B - (A^T B)^T (A^T A)^+ (A^T B),
  //   s = B~^T r~ = B^T r - (A^T B)^T (A^T A)^+ (A^T r).
  std::map<const double*, size_t> owner;  // nuisance block -> its cluster
  Dense h(static_cast<size_t>(m * m), 0.0), meat(static_cast<size_t>(m * m), 0.0);
  int groups = 0;
  std::vector<double*> blocks;
  for (size_t c = 0; c < clusters.size(); ++c) {
    std::map<const double*, int> nuisance_column;
    int p = 0;
    size_t rows_total = 0;
    for (ceres::ResidualBlockId id : clusters[c]) {
      problem.GetParameterBlocksForResidualBlock(id, &blocks);
      for (double* block : blocks) {
        if (problem.IsParameterBlockConstant(block) || interest_column.count(block) != 0) continue;
        const auto [it, inserted] = owner.emplace(block, c);
        if (!inserted && it->second != c) {
          return absl::InvalidArgumentError(
              absl::StrCat("clustered covariance: a parameter block not of interest is shared by clusters ",
                           it->second, " and ", c));
        }
        if (nuisance_column.emplace(block, p).second) p += problem.ParameterBlockTangentSize(block);
      }
      rows_total += static_cast<size_t>(problem.GetCostFunctionForResidualBlock(id)->num_residuals());
    }
    if (rows_total == 0) continue;
    ++groups;
    Dense aa(static_cast<size_t>(p * p), 0.0), ab(static_cast<size_t>(p * m), 0.0), bb(static_cast<size_t>(m * m), 0.0);
    std::vector<double> ar(static_cast<size_t>(p), 0.0), br(static_cast<size_t>(m), 0.0);
    std::vector<double> row_a(static_cast<size_t>(p)), row_b(static_cast<size_t>(m));
    for (ceres::ResidualBlockId id : clusters[c]) {
      problem.GetParameterBlocksForResidualBlock(id, &blocks);
      const int rows = problem.GetCostFunctionForResidualBlock(id)->num_residuals();
      std::vector<std::vector<double>> jacobian(blocks.size());
      std::vector<double*> jacobian_ptr(blocks.size(), nullptr);
      for (size_t i = 0; i < blocks.size(); ++i) {
        if (problem.IsParameterBlockConstant(blocks[i])) continue;
        jacobian[i].resize(static_cast<size_t>(rows * problem.ParameterBlockTangentSize(blocks[i])));
        jacobian_ptr[i] = jacobian[i].data();
      }
      double cost = 0;
      std::vector<double> residual(static_cast<size_t>(rows));
      if (!problem.EvaluateResidualBlock(id, /*apply_loss_function=*/true, &cost, residual.data(),
                                         jacobian_ptr.data())) {
        return absl::InternalError("clustered covariance: a residual block could not be evaluated");
      }
      for (int k = 0; k < rows; ++k) {
        std::fill(row_a.begin(), row_a.end(), 0.0);
        std::fill(row_b.begin(), row_b.end(), 0.0);
        for (size_t i = 0; i < blocks.size(); ++i) {
          if (jacobian_ptr[i] == nullptr) continue;
          const int size = problem.ParameterBlockTangentSize(blocks[i]);
          const auto in = interest_column.find(blocks[i]);
          std::vector<double>& target = in != interest_column.end() ? row_b : row_a;
          const int column = in != interest_column.end() ? in->second : nuisance_column.at(blocks[i]);
          for (int j = 0; j < size; ++j) {
            target[static_cast<size_t>(column + j)] += jacobian[i][static_cast<size_t>(k * size + j)];
          }
        }
        const double rk = residual[static_cast<size_t>(k)];
        for (int i = 0; i < p; ++i) {
          const double ai = row_a[static_cast<size_t>(i)];
          if (ai == 0.0) continue;
          ar[static_cast<size_t>(i)] += ai * rk;
          for (int j = 0; j < p; ++j) aa[static_cast<size_t>(i * p + j)] += ai * row_a[static_cast<size_t>(j)];
          for (int j = 0; j < m; ++j) ab[static_cast<size_t>(i * m + j)] += ai * row_b[static_cast<size_t>(j)];
        }
        for (int i = 0; i < m; ++i) {
          const double bi = row_b[static_cast<size_t>(i)];
          if (bi == 0.0) continue;
          br[static_cast<size_t>(i)] += bi * rk;
          for (int j = 0; j < m; ++j) bb[static_cast<size_t>(i * m + j)] += bi * row_b[static_cast<size_t>(j)];
        }
      }
    }
    std::vector<double> score = br;
    if (p > 0) {
      // Profile the cluster's own parameters out.
      const Dense pinv = PseudoInverse(p, aa, 1e-12);
      Dense pab(static_cast<size_t>(p * m), 0.0);  // (A^T A)^+ A^T B
      std::vector<double> par(static_cast<size_t>(p), 0.0);
      for (int i = 0; i < p; ++i) {
        for (int k = 0; k < p; ++k) {
          const double v = pinv[static_cast<size_t>(i * p + k)];
          par[static_cast<size_t>(i)] += v * ar[static_cast<size_t>(k)];
          for (int j = 0; j < m; ++j) pab[static_cast<size_t>(i * m + j)] += v * ab[static_cast<size_t>(k * m + j)];
        }
      }
      for (int i = 0; i < m; ++i) {
        for (int k = 0; k < p; ++k) {
          const double abki = ab[static_cast<size_t>(k * m + i)];
          score[static_cast<size_t>(i)] -= abki * par[static_cast<size_t>(k)];
          for (int j = 0; j < m; ++j) bb[static_cast<size_t>(i * m + j)] -= abki * pab[static_cast<size_t>(k * m + j)];
        }
      }
    }
    for (size_t i = 0; i < h.size(); ++i) h[i] += bb[i];
    for (int i = 0; i < m; ++i) {
      for (int j = 0; j < m; ++j) {
        meat[static_cast<size_t>(i * m + j)] += score[static_cast<size_t>(i)] * score[static_cast<size_t>(j)];
      }
    }
  }
  if (groups < 2) {
    return absl::InvalidArgumentError("clustered covariance: fewer than two clusters have residuals");
  }
  int rank = 0;
  const Dense h_inverse = PseudoInverse(m, h, 1e-12, &rank);
  if (rank < m) {
    return absl::FailedPreconditionError("clustered covariance: the parameters of interest are not identifiable");
  }
  // H^-1 M H^-1, times G / (G - 1).
  Dense left(static_cast<size_t>(m * m), 0.0);
  for (int i = 0; i < m; ++i) {
    for (int k = 0; k < m; ++k) {
      const double v = h_inverse[static_cast<size_t>(i * m + k)];
      for (int j = 0; j < m; ++j) left[static_cast<size_t>(i * m + j)] += v * meat[static_cast<size_t>(k * m + j)];
    }
  }
  const double correction = static_cast<double>(groups) / (groups - 1.0);
  SymmetricMatrix& result = out.covariance;
  result.size = m;
  result.values.assign(static_cast<size_t>(m * m), 0.0);
  for (int i = 0; i < m; ++i) {
    for (int k = 0; k < m; ++k) {
      const double v = left[static_cast<size_t>(i * m + k)];
      for (int j = 0; j < m; ++j) {
        result.values[static_cast<size_t>(i * m + j)] += v * h_inverse[static_cast<size_t>(k * m + j)] * correction;
      }
    }
  }
  return out;
}

}  // namespace mvbrdf::calibrate
