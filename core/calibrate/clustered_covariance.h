// Cluster-robust ("sandwich") covariance of a solved Ceres problem's
// parameters of interest, for residuals that are correlated within groups.
//
// Ceres's own Covariance is (J^T J)^-1 scaled by one residual variance: right
// when every residual is independent noise. The refinements' residuals are
// not: a light's Samples of one triangle share that triangle's model error
// (its colour varies over the triangle, its Samples are taken at one centre
// and one normal), a camera's contour pairs of one frame share that frame's
// edge. Measured on clean data, that covariance put the light directions'
// sigma ~9x below their actual error (issue #14). The sandwich
//   H^-1 M H^-1,  H = sum_c B~_c^T B~_c,  M = G/(G-1) sum_c s_c s_c^T,
//   s_c = B~_c^T r~_c
// over the G clusters c takes the scatter of each cluster's score instead,
// whatever the correlation inside a cluster. Parameter blocks that only one
// cluster's residuals touch (a triangle's kd) are nuisances profiled out per
// cluster (B~, r~: B and r with their projection on those columns removed);
// blocks of interest may be touched by any cluster. Jacobians and residuals
// are Ceres's with the loss function applied (so robust fits are covered) and
// in each block's tangent space (a direction on the unit sphere has 2 columns).
// No dynamic-size Eigen here: Debian's libceres calls Eigen templates it
// does not inline (ColPivHouseholderQR's constructor in its dense SVD), and
// an instantiation of ours in the executable preempts its own; under ASan
// ours allocates with Eigen's handmade aligned malloc and libceres frees with
// free() (the sanitizer suite's bad-free in RefineCameras' covariance when
// this file used Eigen::MatrixXd and its complete orthogonal decomposition).
#ifndef MVBRDF_CORE_CALIBRATE_CLUSTERED_COVARIANCE_H_
#define MVBRDF_CORE_CALIBRATE_CLUSTERED_COVARIANCE_H_

#include <ceres/ceres.h>

#include <vector>

#include "absl/status/statusor.h"

namespace mvbrdf::calibrate {

// A symmetric n x n matrix, row-major.
struct SymmetricMatrix {
  int size = 0;
  std::vector<double> values;
  double operator()(int i, int j) const { return values[static_cast<size_t>(i * size + j)]; }
};

// ClusteredCovariance's result: the covariance and, per block of interest
// (in the order given), its first row and column in it (-1: held constant
// or not in the problem, no rows).
struct ClusteredCovarianceResult {
  SymmetricMatrix covariance;
  std::vector<int> offset;
};

// The covariance of `interest` (their tangent spaces stacked in that order;
// blocks held constant contribute no columns) from the residual blocks of
// `clusters`. Residual blocks in no cluster are left out. INVALID_ARGUMENT
// when a block not of interest is touched by two clusters or when fewer than
// two clusters have residuals; FAILED_PRECONDITION when the interest is not
// identifiable (H singular to 1e-12 of its largest eigenvalue).
absl::StatusOr<ClusteredCovarianceResult> ClusteredCovariance(ceres::Problem& problem, const std::vector<double*>& interest,
                                                    const std::vector<std::vector<ceres::ResidualBlockId>>& clusters);

}  // namespace mvbrdf::calibrate

#endif  // MVBRDF_CORE_CALIBRATE_CLUSTERED_COVARIANCE_H_
