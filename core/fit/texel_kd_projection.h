// The variable projection shared by the lobe fits with kd free per texel
// (texel_kd_fit.h for the thesis's Phong, lobe_texel_kd_fit.h for any model
// of core/brdf): one colour channel, the lobe's shape fixed, the model
//
//   r_i  ~  kd_{t(i)} G_i + p0 S1_i + S0_i
//
// is linear in the per-texel kd and in the lobe's scale p0. kd_t is
// eliminated in closed form per texel and p0 solves one normal equation,
//
//   p0 = (sum S1 r' - sum_t B_t C_t / A_t) / (sum S1^2 - sum_t B_t^2 / A_t),
//   r' = r - S0,  A_t = sum_t G^2,  B_t = sum_t G S1,  C_t = sum_t G r',
//
// and the shape is searched over an interval (a grid, then a golden section
// between the best grid point's neighbours). The caller supplies the
// regressors G, S1, S0 of every Sample at a shape; the arithmetic is the one
// both fits had, so the Phong path's figures do not move.
#ifndef MVBRDF_CORE_FIT_TEXEL_KD_PROJECTION_H_
#define MVBRDF_CORE_FIT_TEXEL_KD_PROJECTION_H_

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace mvbrdf::fit::internal {

// Dense texel indices 0..num_texels-1 of the Samples' elements (in element
// order), and their count in `num_texels`.
std::vector<uint32_t> DenseTexels(const std::vector<uint32_t>& elements, size_t* num_texels);

class TexelKdProblem {
 public:
  // Fills G, S1, S0 (one value per Sample, sized by the callee) at `shape`.
  using Regressors =
      std::function<void(double shape, std::vector<double>* g, std::vector<double>* s1, std::vector<double>* s0)>;

  // Per Sample: its dense texel, its frame parity (the held-out check) and
  // this channel's reflectance. p0 is kept in [0, p0_max]. The vectors must
  // outlive the problem.
  TexelKdProblem(const std::vector<uint32_t>& texel, const std::vector<uint8_t>& fold, size_t num_texels,
                 std::vector<double> r, double p0_max, Regressors regressors);

  struct Evaluation {
    double p0 = 0.0;
    double cost = 0.0;         // 0.5 sum of squared residuals with per-texel kd
    double information = 0.0;  // (sum S1^2 - sum B^2 / A) / sum S1^2
    double kd = 0.0;           // the cluster's kd at (p0, shape)
  };

  // At `shape` with p0 solved (fixed_p0 < 0) or given.
  Evaluation Evaluate(double shape, double fixed_p0 = -1.0);

  // The lobe (p0, shape) on frames it was not fitted to: per texel, kd from
  // the Samples of one frame parity, the squared error on those of the other,
  // both ways; texels seen in one parity only do not count. Returns the mean
  // squared error and the number of Samples it is over in `count`.
  double HeldOutError(double p0, double shape, size_t* count);

  // The shape of least cost: a grid of `grid_points` over [lo, hi] in the
  // search variable u (shape = shape_of(u)), then `golden_iterations` of a
  // golden section between the best grid point's neighbours.
  struct Search {
    double u = 0.0;
    Evaluation at;
  };
  // `penalty(u)`, when given, is added to the cost compared (not to the
  // returned Evaluation's cost): a prior on the searched variable.
  Search SearchShape(double lo, double hi, int grid_points, int golden_iterations,
                     const std::function<double(double)>& shape_of,
                     const std::function<double(double)>& penalty = nullptr);

 private:
  struct Sums {
    double a = 0.0, b = 0.0, c = 0.0, ss = 0.0, sr = 0.0, rr = 0.0;
  };
  const std::vector<uint32_t>& texel_;
  const std::vector<uint8_t>& fold_;
  const std::vector<double> r_;
  const double p0_max_;
  const Regressors regressors_;
  std::vector<Sums> sums_;
  std::vector<double> g_, s1_, s0_;
};

}  // namespace mvbrdf::fit::internal

#endif  // MVBRDF_CORE_FIT_TEXEL_KD_PROJECTION_H_
