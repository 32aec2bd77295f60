#include "core/brdf/model.h"

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/brdf/blinn_phong.h"
#include "core/brdf/ggx.h"
#include "core/brdf/phong.h"

namespace mvbrdf::brdf {

const char* ModelName(Model model) {
  switch (model) {
    case Model::kPhong:
      return Phong::kName;
    case Model::kBlinnPhong:
      return BlinnPhong::kName;
    case Model::kGgx:
      return Ggx::kName;
  }
  return "?";
}

absl::StatusOr<Model> ParseModel(absl::string_view name) {
  for (Model m : kModels) {
    if (name == ModelName(m)) return m;
  }
  return absl::InvalidArgumentError(absl::StrCat("BRDF model \"", name, "\": expected one of phong, blinn-phong, ggx"));
}

bool NeedsHalfVector(Model model) { return model != Model::kPhong; }

std::array<const char*, 2> ParameterNames(Model model) {
  switch (model) {
    case Model::kPhong:
      return {Phong::Parameters()[0].name, Phong::Parameters()[1].name};
    case Model::kBlinnPhong:
      return {BlinnPhong::Parameters()[0].name, BlinnPhong::Parameters()[1].name};
    case Model::kGgx:
      return {Ggx::Parameters()[0].name, Ggx::Parameters()[1].name};
  }
  return {"?", "?"};
}

}  // namespace mvbrdf::brdf
