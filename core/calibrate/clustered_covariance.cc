#include "core/calibrate/clustered_covariance.h"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <map>

#include "absl/strings/str_cat.h"

namespace mvbrdf::calibrate {

absl::StatusOr<Eigen::MatrixXd> ClusteredCovariance(ceres::Problem& problem, const std::vector<double*>& interest,
                                                    const std::vector<std::vector<ceres::ResidualBlockId>>& clusters) {
  // Columns of interest: the tangent spaces of the variable blocks, stacked.
  std::map<const double*, int> interest_column;
  int m = 0;
  for (double* block : interest) {
    if (!problem.HasParameterBlock(block) || problem.IsParameterBlockConstant(block)) continue;
    interest_column[block] = m;
    m += problem.ParameterBlockTangentSize(block);
  }
  if (m == 0) return Eigen::MatrixXd();

  std::map<const double*, size_t> owner;  // nuisance block -> its cluster
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(m, m), meat = Eigen::MatrixXd::Zero(m, m);
  int groups = 0;
  std::vector<double*> blocks;
  for (size_t c = 0; c < clusters.size(); ++c) {
    // This cluster's nuisance columns and its rows.
    std::map<const double*, int> nuisance_column;
    int p = 0, n = 0;
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
      n += problem.GetCostFunctionForResidualBlock(id)->num_residuals();
    }
    if (n == 0) continue;
    ++groups;
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, p), b = Eigen::MatrixXd::Zero(n, m);
    Eigen::VectorXd r(n);
    int row = 0;
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
      for (int k = 0; k < rows; ++k) r(row + k) = residual[static_cast<size_t>(k)];
      for (size_t i = 0; i < blocks.size(); ++i) {
        if (jacobian_ptr[i] == nullptr) continue;
        const int size = problem.ParameterBlockTangentSize(blocks[i]);
        const auto in = interest_column.find(blocks[i]);
        Eigen::MatrixXd& target = in != interest_column.end() ? b : a;
        const int column = in != interest_column.end() ? in->second : nuisance_column.at(blocks[i]);
        for (int k = 0; k < rows; ++k) {
          for (int j = 0; j < size; ++j) target(row + k, column + j) += jacobian[i][static_cast<size_t>(k * size + j)];
        }
      }
      row += rows;
    }
    if (p > 0) {
      // Profile the cluster's own parameters out: remove the projection on A.
      const Eigen::MatrixXd pinv = (a.transpose() * a).completeOrthogonalDecomposition().pseudoInverse();
      b -= a * (pinv * (a.transpose() * b));
      r -= a * (pinv * (a.transpose() * r));
    }
    h += b.transpose() * b;
    const Eigen::VectorXd score = b.transpose() * r;
    meat += score * score.transpose();
  }
  if (groups < 2) {
    return absl::InvalidArgumentError("clustered covariance: fewer than two clusters have residuals");
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(h);
  const Eigen::VectorXd& lambda = eigen.eigenvalues();  // ascending
  if (!(lambda(m - 1) > 0.0) || !(lambda(0) > 1e-12 * lambda(m - 1))) {
    return absl::FailedPreconditionError("clustered covariance: the parameters of interest are not identifiable");
  }
  const Eigen::MatrixXd h_inverse = eigen.eigenvectors() * lambda.cwiseInverse().asDiagonal() *
                                    eigen.eigenvectors().transpose();
  return (h_inverse * meat * h_inverse) * (static_cast<double>(groups) / (groups - 1.0));
}

}  // namespace mvbrdf::calibrate
