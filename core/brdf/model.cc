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

namespace {

template <typename M>
std::array<const char*, kMaxParameters> NamesOf() {
  std::array<const char*, kMaxParameters> names;
  names.fill("");
  for (int q = 0; q < M::kNumParameters; ++q) names[static_cast<size_t>(q)] = M::Parameters()[static_cast<size_t>(q)].name;
  return names;
}

}  // namespace

int NumParameters(Model model) {
  switch (model) {
    case Model::kPhong:
      return Phong::kNumParameters;
    case Model::kBlinnPhong:
      return BlinnPhong::kNumParameters;
    case Model::kGgx:
      return Ggx::kNumParameters;
  }
  return 2;
}

std::array<const char*, kMaxParameters> ParameterNames(Model model) {
  switch (model) {
    case Model::kPhong:
      return NamesOf<Phong>();
    case Model::kBlinnPhong:
      return NamesOf<BlinnPhong>();
    case Model::kGgx:
      return NamesOf<Ggx>();
  }
  return NamesOf<Phong>();
}

}  // namespace mvbrdf::brdf
