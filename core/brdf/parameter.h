// A BRDF model's parameter: its name (as reports and result.json print it)
// and the bounds a fit keeps it in.
#ifndef MVBRDF_CORE_BRDF_PARAMETER_H_
#define MVBRDF_CORE_BRDF_PARAMETER_H_

namespace mvbrdf::brdf {

struct Parameter {
  const char* name;
  double lower, upper;
};

}  // namespace mvbrdf::brdf

#endif  // MVBRDF_CORE_BRDF_PARAMETER_H_
