#include "core/fit/phong_cost.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/base/vector_exp.h"

namespace mvbrdf::fit::internal {

static_assert(kExpUnderflow == base::kExpFlushBelow, "ExpAffine returns 0 exactly where the terms drop out");

void PhongTerms::Densify(int num_slots) {
  const size_t n = begin.size() - 1, entries = static_cast<size_t>(std::max(num_slots, 0)) * n;
  if (num_slots <= 0 || entries > 2 * slot.size() || entries > kMaxDenseEntries) return;
  dense_slots = num_slots;
  dense_log_h.assign(entries, 0.0);
  dense_offset.assign(entries, kNoHighlight);
  for (size_t i = 0; i < n; ++i) {
    for (uint64_t j = begin[i]; j < begin[i + 1]; ++j) {
      if (log_h[j] == kNoHighlight) continue;  // stays "no term": ln h 0, offset -inf (D's part 0, not NaN)
      const size_t at = static_cast<size_t>(slot[j]) * n + i;
      dense_log_h[at] = log_h[j];
      dense_offset[at] = log_a.empty() ? 0.0 : log_a[j];
    }
  }
}

namespace {

void DenseSpecularSums(const PhongChannelData& data, size_t begin, size_t end, double ke, double* s, double* d) {
  constexpr size_t kBlock = 512;
  double e[kBlock];
  const size_t n = data.size();
  for (size_t block = begin; block < end; block += kBlock) {
    const size_t count = std::min(end, block + kBlock) - block;
    double* sb = s + (block - begin);
    double* db = d == nullptr ? nullptr : d + (block - begin);
    std::fill(sb, sb + count, 0.0);
    if (db != nullptr) std::fill(db, db + count, 0.0);
    for (int k = 0; k < data.dense_slots; ++k) {
      const double w = data.weight[static_cast<size_t>(k)];
      const double* log_h = data.dense_log_h + static_cast<size_t>(k) * n + block;
      base::ExpAffine(count, ke, log_h, data.dense_offset + static_cast<size_t>(k) * n + block, e);
      for (size_t m = 0; m < count; ++m) sb[m] += w * e[m];
      if (db != nullptr) {
        for (size_t m = 0; m < count; ++m) db[m] += w * e[m] * log_h[m];
      }
    }
  }
}

}  // namespace

void SpecularSumsRange(const PhongChannelData& data, size_t begin, size_t end, double ke, double* s, double* d) {
  if (data.dense_slots > 0) {
    DenseSpecularSums(data, begin, end, ke, s, d);
    return;
  }
  // The terms' exponentials a block of samples at a time (a block's terms
  // stay in the L1 cache between the exp and the sums).
  constexpr size_t kBlock = 512;
  thread_local std::vector<double> exps;
  for (size_t block = begin; block < end; block += kBlock) {
    const size_t stop = std::min(end, block + kBlock);
    const size_t first = static_cast<size_t>(data.begin[block]), last = static_cast<size_t>(data.begin[stop]);
    if (exps.size() < last - first) exps.resize(last - first);
    base::ExpAffine(last - first, ke, data.log_h + first, data.log_a == nullptr ? nullptr : data.log_a + first,
                    exps.data());
    const double* e = exps.data();
    for (size_t i = block; i < stop; ++i) {
      double sum = 0.0, dsum = 0.0;
      for (size_t j = static_cast<size_t>(data.begin[i]); j < static_cast<size_t>(data.begin[i + 1]); ++j) {
        const double p = data.weight[data.slot[j]] * e[j - first];
        sum += p;
        dsum += p == 0.0 ? 0.0 : p * data.log_h[j];  // 0, not NaN, for a term with ln h = -inf
      }
      s[i - begin] = sum;
      if (d != nullptr) d[i - begin] = dsum;
    }
  }
}

void EvaluatePhongResiduals(const PhongChannelData& data, size_t begin, size_t end, const double* x, double* residuals,
                            double* jacobian) {
  const double a = x[0], b = x[1], ke = std::exp(x[2]);
  constexpr size_t kChunk = 1024;
  double specular[kChunk], derivative[kChunk];
  for (size_t chunk = begin; chunk < end; chunk += kChunk) {
    const size_t stop = std::min(end, chunk + kChunk);
    SpecularSumsRange(data, chunk, stop, ke, specular, jacobian != nullptr ? derivative : nullptr);
    for (size_t i = chunk; i < stop; ++i) {
      const double s = specular[i - chunk], d = jacobian != nullptr ? derivative[i - chunk] : 0.0;
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
