// A BRDF model's parameter: its name (as reports and result.json print it)
// and the bounds a fit keeps it in.
#ifndef MVBRDF_CORE_BRDF_PARAMETER_H_
#define MVBRDF_CORE_BRDF_PARAMETER_H_

#include <array>

namespace mvbrdf::brdf {

// The most parameters a model of core/brdf has (GGX's f0, roughness,
// f90_ratio); the others have two, and callers size their arrays by this.
constexpr int kMaxParameters = 3;

// A model's parameter values in its order (entries past the model's count
// unused).
using ParameterVector = std::array<double, kMaxParameters>;

struct Parameter {
  const char* name;
  double lower, upper;
};

}  // namespace mvbrdf::brdf

#endif  // MVBRDF_CORE_BRDF_PARAMETER_H_
