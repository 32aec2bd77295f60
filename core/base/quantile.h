// Order statistics shared by the layers (medians and percentiles of errors,
// residuals, figures for reports).
#ifndef MVBRDF_CORE_BASE_QUANTILE_H_
#define MVBRDF_CORE_BASE_QUANTILE_H_

#include <vector>

namespace mvbrdf {

// The q-quantile (q in [0, 1]) of `values`: the element of rank
// min(n - 1, floor(q n)) (q = 0.5: the upper median); 0 when empty.
double Quantile(std::vector<double> values, double q);

}  // namespace mvbrdf

#endif  // MVBRDF_CORE_BASE_QUANTILE_H_
