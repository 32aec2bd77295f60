#include "core/fit/phong_cost.h"

#include <algorithm>
#include <cmath>

namespace mvbrdf::fit::internal {

void EvaluatePhongResiduals(const PhongChannelData& data, size_t begin, size_t end, const double* x, double* residuals,
                            double* jacobian) {
  const double a = x[0], b = x[1], ke = std::exp(x[2]);
  for (size_t i = begin; i < end; ++i) {
    double s, d;
    SpecularSums(data, i, ke, &s, &d);
    const double g = data.diffuse[i];
    const double w = data.sqrt_weight.empty() ? 1.0 : data.sqrt_weight[i];
    residuals[i - begin] = w * (data.r[i] - (a * g + b * s));
    if (jacobian != nullptr) {
      double* row = jacobian + 3 * (i - begin);
      row[0] = -w * g;
      row[1] = -w * s;
      row[2] = -w * b * d * ke;
    }
  }
}

double PhongCost(const PhongChannelData& data, const double* x) {
  constexpr size_t kChunk = 1024;
  double residuals[kChunk];
  double sum = 0.0;
  for (size_t begin = 0; begin < data.size(); begin += kChunk) {
    const size_t end = std::min(data.size(), begin + kChunk);
    EvaluatePhongResiduals(data, begin, end, x, residuals, nullptr);
    for (size_t j = 0; j < end - begin; ++j) sum += residuals[j] * residuals[j];
  }
  return 0.5 * sum;
}

PhongBlockCost::PhongBlockCost(const PhongChannelData* data, size_t begin, size_t end)
    : data_(data), begin_(begin), end_(end) {
  set_num_residuals(static_cast<int>(end - begin));
  mutable_parameter_block_sizes()->push_back(3);
}

bool PhongBlockCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  double* jacobian = jacobians != nullptr ? jacobians[0] : nullptr;
  EvaluatePhongResiduals(*data_, begin_, end_, parameters[0], residuals, jacobian);
  return true;
}

}  // namespace mvbrdf::fit::internal
