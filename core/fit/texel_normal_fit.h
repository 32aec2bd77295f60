// Per-texel normals from a texel's observations (issue #18; Lensch et al.,
// TOG 2003, "geometric detail"): the tangent-space normal m (2 DoF) and kd
// per texel that best explain what the cameras saw across frames, lights and
// cameras, given the texel's cluster BRDF. Streamed: one pass over the frames
// adds each observation to per-texel sums, a solve per texel follows.
//
// Closed-form start (the diffuse part, photometric stereo). Channel c of an
// observation r_c, minus the cluster's specular S_c (at the mesh normal):
//   r_c - S_c ~ kd_c sum_j I_jc a_j (m . l_j)          (lights j that light it)
// with l_j the unit direction to light j in the texel's tangent frame
// (scene/tangent_frames.h) and a_j its fall-off. Summed over channels with
// the cluster's kd as weights for the colour (kd_c = kappa kd_c^cluster):
//   y = sum_c (r_c - S_c) ~ b . q,   q = sum_c kd_c^cluster sum_j I_jc a_j l_j,
//   b = kappa m.
// Weighted least squares over the texel's observations, with a prior
// lambda |b - kappa0 z|^2 towards the mesh normal z = (0, 0, 1) (kappa0 the
// scale that fits the mesh normal; lambda = prior_weight x the texel's mean
// w^2 |q|^2 / 3, i.e. prior_weight observations' worth along each axis):
//   (sum w^2 q q^T + lambda I) b = sum w^2 y q + lambda kappa0 z,   m = b / |b|.
//
// Gauss-Newton steps (the full model, specular included). With the current
// m0, e1, e2 an orthonormal basis of the plane orthogonal to it, and
// m(alpha, beta) = normalize(m0 + alpha e1 + beta e2), the unknowns
// x = (alpha, beta, kd_r, kd_g, kd_b) and per observation and channel
//   res_c = r_c - (kd_c G_c(m) + S_c(m)),   J_c = d(kd_c G_c + S_c)/dx
// (G, S as the texel pass reads the cluster's model; d/dalpha, d/dbeta by
// forward differences), each weighted by w_c; priors lambda_n |m - z|^2 and
// lambda_kd |kd - kd^cluster|^2:
//   (sum J^T W J + P) dx = sum J^T W res - p.
// The normal's uncertainty: sigma^2 = cost / (3 n - 5) times the (alpha,
// beta) block of the inverse, reported as its standard deviation in degrees.
//
// Whether to use it at all (a likelihood-ratio test): the same observations
// explained with the mesh normal and the best kd for it,
//   cost_mesh = sum_c min_kd sum w_c^2 (r_c - S_c(z) - kd G_c(z))^2,
// must exceed the refined cost by more than `significance` x its residual
// variance (chi^2 with 2 degrees of freedom: 13.8 at 0.1 %). On a surface the
// mesh models, the refined normal fits noise and is not used.
#ifndef MVBRDF_CORE_FIT_TEXEL_NORMAL_FIT_H_
#define MVBRDF_CORE_FIT_TEXEL_NORMAL_FIT_H_

#include <array>
#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "absl/status/status.h"

namespace mvbrdf::fit {

struct TexelNormalOptions {
  // Pseudo-observations pulling m towards the mesh normal (and, in the
  // Gauss-Newton steps, kd towards the cluster's), at the texel's own
  // typical observation.
  double prior_weight = 1.0;
  // Gauss-Newton passes after the closed-form one (each a pass over every
  // frame); at least 2 (the last one's significance test needs a per-texel
  // kd from the one before).
  int iterations = 2;
  // A texel keeps the mesh normal (flagged) with fewer observations than
  // this, when its light directions are too nearly coplanar (smallest over
  // largest eigenvalue of sum w^2 q q^T below min_conditioning), or when the
  // refined normal tilts more than max_tilt_deg from the mesh's.
  int min_observations = 8;
  double min_conditioning = 1e-4;
  double max_tilt_deg = 60.0;
  // At most this rotation of m per Gauss-Newton step.
  double max_step_deg = 15.0;
  // The likelihood-ratio test's threshold (chi^2, 2 degrees of freedom).
  double significance = 13.8;

  absl::Status Check() const;
};

// Per texel: why it keeps the mesh normal (0: refined).
enum TexelNormalFlag : uint8_t {
  kNormalFewObservations = 1,
  kNormalCoplanarLights = 2,
  kNormalAtTiltLimit = 4,
  // The refined normal explains the observations no better than the mesh's
  // by more than fitting two more parameters to noise would (see
  // NormalGaussNewtonSums::Significant).
  kNormalNotSignificant = 8,
};

// The closed-form pass's sums.
class NormalStereoSums {
 public:
  explicit NormalStereoSums(size_t texels) : s_(texels, Entry{}) {}
  // One observation of `texel` (see above); w is the observation's square
  // root weight. Texels may be added from several threads when each thread
  // owns its texels.
  void Add(size_t texel, double w, double y, const glm::dvec3& q);
  struct Solution {
    glm::vec3 m{0.0f, 0.0f, 1.0f};
    uint8_t flags = 0;  // TexelNormalFlag
    uint32_t observations = 0;
  };
  Solution Solve(size_t texel, const TexelNormalOptions& options) const;

 private:
  struct Entry {
    std::array<double, 6> a{};  // sum w^2 q q^T: xx, xy, xz, yy, yz, zz
    std::array<double, 3> c{};  // sum w^2 y q
    uint32_t n = 0;
  };
  std::vector<Entry> s_;
};

// An orthonormal basis (e1, e2) of the plane orthogonal to unit m, and
// m(alpha, beta) = normalize(m + alpha e1 + beta e2).
struct NormalTangentBasis {
  glm::dvec3 m, e1, e2;
  explicit NormalTangentBasis(const glm::dvec3& unit_m);
  glm::dvec3 At(double alpha, double beta) const { return glm::normalize(m + alpha * e1 + beta * e2); }
};

// One Gauss-Newton pass's sums.
class NormalGaussNewtonSums {
 public:
  explicit NormalGaussNewtonSums(size_t texels) : s_(texels, Entry{}) {}
  // One observation, channel by channel: residual res[c], Jacobian row
  // j[c] = d model_c / d(alpha, beta, kd_r, kd_g, kd_b) (only kd_c's column
  // non-zero among the kd), square root weight w[c].
  void Add(size_t texel, const std::array<std::array<double, 5>, 3>& j, const glm::dvec3& res, const glm::dvec3& w);
  // The same observation at the mesh normal: res_z = r - S(z), g_z = G(z)
  // per channel (for the test above).
  void AddMeshNormal(size_t texel, const glm::dvec3& res_z, const glm::dvec3& g_z, const glm::dvec3& w);
  // Whether the refined normal explains the texel's observations
  // significantly better than the mesh's (only with AddMeshNormal's sums).
  bool Significant(size_t texel, const TexelNormalOptions& options) const;
  struct Step {
    double alpha = 0.0, beta = 0.0;
    glm::dvec3 kd{0.0};      // the new kd
    double sigma_deg = 0.0;  // the normal's standard deviation
    bool ok = false;         // false: no observations or a singular system
  };
  // The step from (basis.m, kd) with the priors towards z = (0, 0, 1) and
  // `cluster_kd`.
  Step Solve(size_t texel, const NormalTangentBasis& basis, const glm::dvec3& kd, const glm::dvec3& cluster_kd,
             const TexelNormalOptions& options) const;

 private:
  struct Entry {
    std::array<double, 15> h{};  // sum J^T W J, upper triangle row by row
    std::array<double, 5> g{};   // sum J^T W res
    double cost = 0.0;           // sum W res^2
    uint32_t n = 0;              // observations (3 channels each)
    // At the mesh normal, per channel: sum w^2 res_z^2, w^2 res_z g_z, w^2 g_z^2.
    std::array<double, 9> mesh{};
  };
  std::vector<Entry> s_;
};

}  // namespace mvbrdf::fit

#endif  // MVBRDF_CORE_FIT_TEXEL_NORMAL_FIT_H_
