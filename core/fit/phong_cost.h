// The least-squares cost of one colour channel of the Phong fit, in the
// normalised units the solvers work in (see phong_fit.cc for the scaling).
//
// Data per sample i (already restricted to the lights k of the mask and made
// scale-free):
//
//   r_i       reflectance / r_scale
//   G_i     = sum_k w_k g_ik                   diffuse illumination
//   L_ik    = ln h_ik  (h_ik in (0, 1]), or "none" where h_ik = 0
//   w_k     = I_k / I_max                      per-light weight, in [0, 1]
//
// Parameters x = (a, b, t): a = kd * I_max / r_scale, b = ks * I_max / r_scale,
// t = ln ke. With ke = e^t and the specular sum
//
//   S_i(t)  = sum_k w_k exp(ke L_ik)           (= sum_k w_k h_ik^ke)
//   D_i(t)  = sum_k w_k exp(ke L_ik) L_ik      (= dS_i / dke)
//
// the model, residual and cost are
//
//   f_i     = a G_i + b S_i(t)
//   rho_i   = r_i - f_i
//   C(x)    = 1/2 sum_i rho_i^2
//
// and the Jacobian of the residual (dke/dt = ke):
//
//   d rho_i / da = -G_i
//   d rho_i / db = -S_i
//   d rho_i / dt = -b D_i ke
//
// Lights with h = 0 contribute nothing to S and D (no log(0) is taken).
// Every term is finite: L <= 0 and ke <= 1e4 keep exp(ke L) in [0, 1], and
// for a huge ke * |L| it underflows to 0, which makes D's term 0 too.
#ifndef MVBRDF_CORE_FIT_PHONG_COST_H_
#define MVBRDF_CORE_FIT_PHONG_COST_H_

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "ceres/cost_function.h"

namespace mvbrdf::fit::internal {

// Marks L_ik for h_ik = 0.
constexpr double kNoHighlight = -std::numeric_limits<double>::infinity();

// One channel's data. The specular terms (lights with h > 0) of sample i
// are j in [begin[i], begin[i + 1]) (CSR, size() + 1 offsets): slot[j]
// indexes `weight`, log_h[j] = ln h. Shared by the three channels and owned
// by the caller (PhongTerms).
struct PhongChannelData {
  const uint64_t* begin = nullptr;
  const uint16_t* slot = nullptr;
  const double* log_h = nullptr;
  // Optional, per term like log_h: ln a of the inverse-square fall-off
  // (SampleSet::falloff), added to the exponent: a h^ke = exp(ke ln h + ln a).
  const double* log_a = nullptr;
  std::vector<double> weight;   // w per light slot
  std::vector<double> r;        // r_i
  std::vector<double> diffuse;  // G_i
  // Optional (robust fits, IRLS): sqrt(w_i), multiplying rho_i and its
  // Jacobian row, so that C(x) = 1/2 sum_i w_i rho_i^2. Empty: w_i = 1.
  std::vector<double> sqrt_weight;
  // Optional, the same terms laid out densely (PhongTerms::Densify), which
  // SpecularSumsRange then reads instead: dense_slots rows of size() values,
  // slot-major; dense_log_h[k * size() + i] is ln h of sample i's term of slot
  // k and dense_offset[...] its ln a (0 without fall-off); a sample without a
  // term of slot k has ln h = 0 and offset -inf (its exp is 0, and so is its
  // part of D).
  int dense_slots = 0;
  const double* dense_log_h = nullptr;
  const double* dense_offset = nullptr;
  size_t size() const { return r.size(); }
};

// Owner of PhongChannelData's term arrays.
struct PhongTerms {
  std::vector<uint64_t> begin = {0};
  std::vector<uint16_t> slot;
  std::vector<double> log_h, log_a;
  // Appends one sample from a dense row of `num_slots` ln h values
  // (kNoHighlight: no term) and optionally ln a values.
  void AddDense(int num_slots, const double* log_h_row, const double* log_a_row = nullptr) {
    for (int k = 0; k < num_slots; ++k) {
      if (log_h_row[k] == -std::numeric_limits<double>::infinity()) continue;
      slot.push_back(static_cast<uint16_t>(k));
      log_h.push_back(log_h_row[k]);
      if (log_a_row != nullptr) log_a.push_back(log_a_row[k]);
    }
    begin.push_back(slot.size());
  }
  // The dense layout (PhongChannelData::dense_*), slot-major.
  int dense_slots = 0;
  std::vector<double> dense_log_h, dense_offset;

  // Empties the terms, keeping the arrays' memory for the next fit.
  void Clear() {
    begin.assign(1, 0);
    slot.clear();
    log_h.clear();
    log_a.clear();
    dense_slots = 0;
    dense_log_h.clear();
    dense_offset.clear();
  }
  size_t CapacityBytes() const {
    return begin.capacity() * sizeof(uint64_t) + slot.capacity() * sizeof(uint16_t) +
           (log_h.capacity() + log_a.capacity() + dense_log_h.capacity() + dense_offset.capacity()) * sizeof(double);
  }

  // Lays the terms out densely as well when that costs at most twice the
  // exponentials (num_slots x samples <= 2 x terms: few lights, most of them
  // with a highlight term, as in the sweep's and clusters' fits; not OLAT's
  // one light in 96) and at most kMaxDenseEntries entries. The dense sums
  // vectorise across samples; the CSR ones loop over 1-4 terms per sample.
  static constexpr size_t kMaxDenseEntries = size_t{1} << 21;  // 32 MiB for both arrays
  void Densify(int num_slots);

  void Attach(PhongChannelData* data) const {
    data->begin = begin.data();
    data->slot = slot.data();
    data->log_h = log_h.data();
    data->log_a = log_a.empty() ? nullptr : log_a.data();
    data->dense_slots = dense_slots;
    data->dense_log_h = dense_slots > 0 ? dense_log_h.data() : nullptr;
    data->dense_offset = dense_slots > 0 ? dense_offset.data() : nullptr;
  }
};

// Below this exp() returns at most ~3e-308 (a subnormal from ~-708.4, then 0).
constexpr double kExpUnderflow = -708.0;

// S_i (and D_i when d is not null) of the samples i in [begin, end) into
// s[i - begin] (d[i - begin]), from the dense layout when the data has one,
// else from the CSR terms. The exponentials of a block's terms are taken at
// once (base::ExpAffine, vectorised, within 2 ulp of std::exp). A term whose
// exponent ke ln h + ln a is below kExpUnderflow adds 0: exp would return a
// subnormal or 0 there, several times slower, and such a term adds nothing a
// double can hold beside the others (a third of the terms at ke = 1000).
void SpecularSumsRange(const PhongChannelData& data, size_t begin, size_t end, double ke, double* s, double* d);

// rho_i for i in [begin, end) into residuals[i - begin]; the Jacobian rows
// (row-major, 3 per residual) into `jacobian` when not null.
void EvaluatePhongResiduals(const PhongChannelData& data, size_t begin, size_t end, const double* x, double* residuals,
                            double* jacobian);

// C(x) over all samples.
double PhongCost(const PhongChannelData& data, const double* x);

// The analytic cost of a block of samples [begin, end) (Ceres: one residual
// block of end - begin residuals and one parameter block x of size 3). The
// block count is chosen at run time, so this is a ceres::CostFunction with
// set_num_residuals rather than a SizedCostFunction. `data` must outlive it.
class PhongBlockCost : public ceres::CostFunction {
 public:
  static ceres::CostFunction* Create(const PhongChannelData* data, size_t begin, size_t end) {
    return new PhongBlockCost(data, begin, end);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  PhongBlockCost(const PhongChannelData* data, size_t begin, size_t end);

  const PhongChannelData* data_;
  size_t begin_, end_;
};

}  // namespace mvbrdf::fit::internal

#endif  // MVBRDF_CORE_FIT_PHONG_COST_H_
