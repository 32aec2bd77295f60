#include "core/fit/texel_normal_fit.h"

#include <Eigen/Dense>
#include <cmath>

#include "absl/strings/str_cat.h"

namespace mvbrdf::fit {
namespace {

constexpr double kDegrees = 180.0 / 3.14159265358979323846;

}  // namespace

absl::Status TexelNormalOptions::Check() const {
  if (!(prior_weight >= 0.0) || !std::isfinite(prior_weight)) {
    return absl::InvalidArgumentError(absl::StrCat("normals.prior_weight: must be >= 0, got ", prior_weight));
  }
  // At least 2: the last pass's test compares the refined normal with the
  // per-texel kd of a step before it.
  if (iterations < 2 || iterations > 20) {
    return absl::InvalidArgumentError(absl::StrCat("normals.iterations: must be in [2, 20], got ", iterations));
  }
  if (min_observations < 3) {
    return absl::InvalidArgumentError(absl::StrCat("normals.min_observations: must be >= 3, got ", min_observations));
  }
  if (!(min_conditioning >= 0.0 && min_conditioning < 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("normals.min_conditioning: must be in [0, 1), got ", min_conditioning));
  }
  if (!(max_tilt_deg > 0.0 && max_tilt_deg < 90.0)) {
    return absl::InvalidArgumentError(absl::StrCat("normals.max_tilt_deg: must be in (0, 90), got ", max_tilt_deg));
  }
  if (!(significance >= 0.0) || !std::isfinite(significance)) {
    return absl::InvalidArgumentError(absl::StrCat("normals.significance: must be >= 0, got ", significance));
  }
  if (!(max_step_deg > 0.0 && max_step_deg < 90.0)) {
    return absl::InvalidArgumentError(absl::StrCat("normals.max_step_deg: must be in (0, 90), got ", max_step_deg));
  }
  return absl::OkStatus();
}

void NormalStereoSums::Add(size_t texel, double w, double y, const glm::dvec3& q) {
  Entry& e = s_[texel];
  const double w2 = w * w;
  e.a[0] += w2 * q.x * q.x;
  e.a[1] += w2 * q.x * q.y;
  e.a[2] += w2 * q.x * q.z;
  e.a[3] += w2 * q.y * q.y;
  e.a[4] += w2 * q.y * q.z;
  e.a[5] += w2 * q.z * q.z;
  e.c[0] += w2 * y * q.x;
  e.c[1] += w2 * y * q.y;
  e.c[2] += w2 * y * q.z;
  ++e.n;
}

NormalStereoSums::Solution NormalStereoSums::Solve(size_t texel, const TexelNormalOptions& options) const {
  const Entry& e = s_[texel];
  Solution out;
  out.observations = e.n;
  if (e.n < static_cast<uint32_t>(options.min_observations)) {
    out.flags = kNormalFewObservations;
    return out;
  }
  Eigen::Matrix3d a;
  a << e.a[0], e.a[1], e.a[2], e.a[1], e.a[3], e.a[4], e.a[2], e.a[4], e.a[5];
  const Eigen::Vector3d c(e.c[0], e.c[1], e.c[2]);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(a, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d values = eigen.eigenvalues();  // ascending
  if (!(values(2) > 0.0) || !(values(0) >= options.min_conditioning * values(2))) {
    out.flags = kNormalCoplanarLights;
    return out;
  }
  // The mesh normal's scale, and the prior towards it.
  const double kappa0 = a(2, 2) > 0.0 ? c(2) / a(2, 2) : 0.0;
  const double lambda = options.prior_weight * a.trace() / (3.0 * static_cast<double>(e.n));
  const Eigen::Vector3d b =
      (a + lambda * Eigen::Matrix3d::Identity()).ldlt().solve(c + lambda * kappa0 * Eigen::Vector3d::UnitZ());
  const double length = b.norm();
  if (!(length > 0.0) || !std::isfinite(length) || !(b(2) > 0.0)) {
    out.flags = kNormalAtTiltLimit;
    return out;
  }
  const glm::dvec3 m(b(0) / length, b(1) / length, b(2) / length);
  if (std::acos(std::min(1.0, m.z)) * kDegrees > options.max_tilt_deg) {
    out.flags = kNormalAtTiltLimit;
    return out;
  }
  out.m = glm::vec3(m);
  return out;
}

NormalTangentBasis::NormalTangentBasis(const glm::dvec3& unit_m) : m(unit_m) {
  const glm::dvec3 helper = std::fabs(m.x) < 0.9 ? glm::dvec3(1.0, 0.0, 0.0) : glm::dvec3(0.0, 1.0, 0.0);
  e1 = glm::normalize(glm::cross(helper, m));
  e2 = glm::cross(m, e1);
}

void NormalGaussNewtonSums::Add(size_t texel, const std::array<std::array<double, 5>, 3>& j, const glm::dvec3& res,
                                const glm::dvec3& w) {
  Entry& e = s_[texel];
  for (int c = 0; c < 3; ++c) {
    const double w2 = w[c] * w[c];
    int k = 0;
    for (int r = 0; r < 5; ++r) {
      e.g[static_cast<size_t>(r)] += w2 * j[static_cast<size_t>(c)][static_cast<size_t>(r)] * res[c];
      for (int s = r; s < 5; ++s, ++k) {
        e.h[static_cast<size_t>(k)] +=
            w2 * j[static_cast<size_t>(c)][static_cast<size_t>(r)] * j[static_cast<size_t>(c)][static_cast<size_t>(s)];
      }
    }
    e.cost += w2 * res[c] * res[c];
  }
  ++e.n;
}

void NormalGaussNewtonSums::AddMeshNormal(size_t texel, const glm::dvec3& res_z, const glm::dvec3& g_z,
                                          const glm::dvec3& w) {
  Entry& e = s_[texel];
  for (int c = 0; c < 3; ++c) {
    const double w2 = w[c] * w[c];
    e.mesh[static_cast<size_t>(3 * c)] += w2 * res_z[c] * res_z[c];
    e.mesh[static_cast<size_t>(3 * c + 1)] += w2 * res_z[c] * g_z[c];
    e.mesh[static_cast<size_t>(3 * c + 2)] += w2 * g_z[c] * g_z[c];
  }
}

bool NormalGaussNewtonSums::Significant(size_t texel, const TexelNormalOptions& options) const {
  const Entry& e = s_[texel];
  const double dof = 3.0 * static_cast<double>(e.n) - 5.0;
  if (!(dof > 0.0) || !(e.cost > 0.0)) return e.n > 0;
  double mesh_cost = 0.0;
  for (size_t c = 0; c < 3; ++c) {
    const double rr = e.mesh[3 * c], rg = e.mesh[3 * c + 1], gg = e.mesh[3 * c + 2];
    mesh_cost += gg > 0.0 ? rr - rg * rg / gg : rr;
  }
  return mesh_cost - e.cost > options.significance * e.cost / dof;
}

NormalGaussNewtonSums::Step NormalGaussNewtonSums::Solve(size_t texel, const NormalTangentBasis& basis,
                                                         const glm::dvec3& kd, const glm::dvec3& cluster_kd,
                                                         const TexelNormalOptions& options) const {
  const Entry& e = s_[texel];
  Step step;
  step.kd = kd;
  if (e.n == 0) return step;
  Eigen::Matrix<double, 5, 5> h;
  int k = 0;
  for (int r = 0; r < 5; ++r) {
    for (int s = r; s < 5; ++s, ++k) h(r, s) = h(s, r) = e.h[static_cast<size_t>(k)];
  }
  Eigen::Matrix<double, 5, 1> g;
  for (int r = 0; r < 5; ++r) g(r) = e.g[static_cast<size_t>(r)];
  const double n = static_cast<double>(e.n);
  // Priors, prior_weight observations' worth each: m towards z, kd towards
  // the cluster's.
  const double lambda_n = options.prior_weight * (h(0, 0) + h(1, 1)) / (2.0 * n);
  const glm::dvec3 to_z = glm::dvec3(0.0, 0.0, 1.0) - basis.m;
  h(0, 0) += lambda_n;
  h(1, 1) += lambda_n;
  g(0) += lambda_n * glm::dot(basis.e1, to_z);
  g(1) += lambda_n * glm::dot(basis.e2, to_z);
  for (int c = 0; c < 3; ++c) {
    const double lambda_kd = options.prior_weight * h(2 + c, 2 + c) / n;
    h(2 + c, 2 + c) += lambda_kd;
    g(2 + c) += lambda_kd * (cluster_kd[c] - kd[c]);
  }
  const Eigen::LDLT<Eigen::Matrix<double, 5, 5>> ldlt(h);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return step;
  const Eigen::Matrix<double, 5, 1> dx = ldlt.solve(g);
  if (!dx.allFinite()) return step;
  double alpha = dx(0), beta = dx(1);
  const double length = std::hypot(alpha, beta), limit = std::tan(options.max_step_deg / kDegrees);
  if (length > limit) {
    alpha *= limit / length;
    beta *= limit / length;
  }
  step.alpha = alpha;
  step.beta = beta;
  step.kd = kd + glm::dvec3(dx(2), dx(3), dx(4));
  const double dof = 3.0 * n - 5.0;
  if (dof > 0.0) {
    const Eigen::Matrix<double, 5, 5> inverse = ldlt.solve(Eigen::Matrix<double, 5, 5>::Identity());
    const double variance = e.cost / dof * (inverse(0, 0) + inverse(1, 1));
    step.sigma_deg = variance > 0.0 ? std::sqrt(variance) * kDegrees : 0.0;
  }
  step.ok = true;
  return step;
}

}  // namespace mvbrdf::fit
