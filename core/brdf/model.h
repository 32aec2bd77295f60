// The BRDF models a reconstruction can fit and render (issue #15), by name:
// the one enumeration that fitting, rendering, synthesis and the job options
// share. Each model's formulas are its own file (phong.h, blinn_phong.h,
// ggx.h) and GLSL function (shaders/brdf_models.glsl).
#ifndef MVBRDF_CORE_BRDF_MODEL_H_
#define MVBRDF_CORE_BRDF_MODEL_H_

#include <array>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/brdf/parameter.h"

namespace mvbrdf::brdf {

// The values are the GLSL renderer's (shaders/phong.frag u_brdf_model).
enum class Model { kPhong = 0, kBlinnPhong = 1, kGgx = 2 };
constexpr std::array<Model, 3> kModels = {Model::kPhong, Model::kBlinnPhong, Model::kGgx};

// "phong", "blinn-phong", "ggx" (the --brdf values).
const char* ModelName(Model model);
// INVALID_ARGUMENT naming the accepted values.
absl::StatusOr<Model> ParseModel(absl::string_view name);
// Whether the model reads the half-vector geometry (n.v, n.h, v.h).
bool NeedsHalfVector(Model model);
// How many parameters the model has (2; GGX 3), and their names ("ks",
// "ke"; "f0", "roughness", "f90_ratio"), as atlases and reports name them
// (entries past NumParameters are "").
int NumParameters(Model model);
std::array<const char*, kMaxParameters> ParameterNames(Model model);

}  // namespace mvbrdf::brdf

#endif  // MVBRDF_CORE_BRDF_MODEL_H_
