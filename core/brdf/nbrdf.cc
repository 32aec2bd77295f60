#include "core/brdf/nbrdf.h"

#include <google/protobuf/struct.pb.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"

namespace mvbrdf::brdf {
namespace {

using google::protobuf::ListValue;
using google::protobuf::Struct;
using google::protobuf::Value;

constexpr int kNumLayers = 3;
// How many known names an unknown-material error lists.
constexpr int kNamesShown = 8;

// out[j] = b[j] + sum_i in[i] W[i][j] for the packed W [kIn][kOut].
template <int kIn, int kOut>
void Dense(const double* w, const double* b, const double* in, double* out) {
  for (int j = 0; j < kOut; ++j) out[j] = b[j];
  for (int i = 0; i < kIn; ++i) {
    for (int j = 0; j < kOut; ++j) out[j] += in[i] * w[i * kOut + j];
  }
}

// A branchless orthonormal basis (t, b, n) around the unit vector n (Duff et
// al., "Building an Orthonormal Basis, Revisited", JCGT 2017).
void TangentFrame(const glm::dvec3& n, glm::dvec3* t, glm::dvec3* b) {
  const double sign = std::copysign(1.0, n.z);
  const double a = -1.0 / (sign + n.z);
  const double c = n.x * n.y * a;
  *t = glm::dvec3(1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x);
  *b = glm::dvec3(c, sign + n.y * n.y * a, -n.y);
}

// `value`, a list of `count` finite numbers, into out[0 .. count).
absl::Status ReadNumbers(const Value& value, const std::string& field, int count, absl::string_view what, double* out) {
  if (!value.has_list_value()) return absl::InvalidArgumentError(absl::StrCat(field, ": expected a list of ", what));
  const ListValue& list = value.list_value();
  if (list.values_size() != count) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": expected ", count, " ", what, ", got ", list.values_size()));
  }
  for (int i = 0; i < count; ++i) {
    const Value& element = list.values(i);
    if (!element.has_number_value() || !std::isfinite(element.number_value())) {
      return absl::InvalidArgumentError(absl::StrCat(field, "[", i, "]: expected a finite number"));
    }
    out[i] = element.number_value();
  }
  return absl::OkStatus();
}

// One layer {"kernel": [n_in][n_out], "bias": [n_out]} into the packed
// weights at w and b.
absl::Status ReadLayer(const Value& value, const std::string& field, int n_in, int n_out, double* w, double* b) {
  if (!value.has_struct_value()) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": expected an object {\"kernel\", \"bias\"}"));
  }
  const auto& fields = value.struct_value().fields();
  for (const auto& [key, unused] : fields) {
    if (key != "kernel" && key != "bias") {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ".", key, ": unknown key (a layer has \"kernel\" and \"bias\")"));
    }
  }
  const auto kernel = fields.find("kernel");
  if (kernel == fields.end()) return absl::InvalidArgumentError(absl::StrCat(field, ".kernel: missing"));
  const auto bias = fields.find("bias");
  if (bias == fields.end()) return absl::InvalidArgumentError(absl::StrCat(field, ".bias: missing"));

  const std::string kernel_field = absl::StrCat(field, ".kernel");
  const std::string shape = absl::StrCat(" (a ", n_in, "x", n_out, " kernel, [inputs][outputs])");
  if (!kernel->second.has_list_value()) {
    return absl::InvalidArgumentError(absl::StrCat(kernel_field, ": expected a list of lists", shape));
  }
  const ListValue& rows = kernel->second.list_value();
  if (rows.values_size() != n_in) {
    return absl::InvalidArgumentError(
        absl::StrCat(kernel_field, ": expected ", n_in, " rows", shape, ", got ", rows.values_size()));
  }
  for (int i = 0; i < n_in; ++i) {
    MVBRDF_RETURN_IF_ERROR(ReadNumbers(rows.values(i), absl::StrCat(kernel_field, "[", i, "]"), n_out,
                                       absl::StrCat("numbers", shape), w + i * n_out));
  }
  return ReadNumbers(bias->second, absl::StrCat(field, ".bias"), n_out, "numbers", b);
}

// The material `name` of the file's "materials" object; `origin` names the
// file.
absl::StatusOr<NeuralBrdf> ReadMaterial(const Value& value, absl::string_view origin, absl::string_view name) {
  const std::string field = absl::StrCat(origin, ": materials.", name);
  if (!value.has_list_value() || value.list_value().values_size() != kNumLayers) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": expected a list of ", kNumLayers, " layers (a 6-21-21-3 network), got ",
                     value.has_list_value() ? absl::StrCat(value.list_value().values_size()) : "no list"));
  }
  const ListValue& layers = value.list_value();
  std::array<double, NeuralBrdf::kNumWeights> w{};
  MVBRDF_RETURN_IF_ERROR(ReadLayer(layers.values(0), absl::StrCat(field, "[0]"), NeuralBrdf::kInputs,
                                   NeuralBrdf::kHidden, &w[NeuralBrdf::kW1], &w[NeuralBrdf::kB1]));
  MVBRDF_RETURN_IF_ERROR(ReadLayer(layers.values(1), absl::StrCat(field, "[1]"), NeuralBrdf::kHidden,
                                   NeuralBrdf::kHidden, &w[NeuralBrdf::kW2], &w[NeuralBrdf::kB2]));
  MVBRDF_RETURN_IF_ERROR(ReadLayer(layers.values(2), absl::StrCat(field, "[2]"), NeuralBrdf::kHidden,
                                   NeuralBrdf::kOutputs, &w[NeuralBrdf::kW3], &w[NeuralBrdf::kB3]));
  return NeuralBrdf(w);
}

// The file's "materials" object, parsed through Protobuf's JSON mapping.
absl::StatusOr<Struct> ReadMaterials(const std::filesystem::path& json) {
  Struct document;
  MVBRDF_RETURN_IF_ERROR(ReadJsonFile(json, &document));
  const auto materials = document.fields().find("materials");
  if (materials == document.fields().end() || !materials->second.has_struct_value()) {
    return absl::InvalidArgumentError(
        absl::StrCat(json.string(), ": materials: expected an object {NAME: [3 layers of {\"kernel\", \"bias\"}]}"));
  }
  if (materials->second.struct_value().fields().empty()) {
    return absl::InvalidArgumentError(absl::StrCat(json.string(), ": materials: empty"));
  }
  Struct out;
  out.Swap(document.mutable_fields()->at("materials").mutable_struct_value());
  return out;
}

}  // namespace

glm::dvec3 NeuralBrdf::Evaluate(const glm::dvec3& wi, const glm::dvec3& wo) const {
  if (!(wi.z > 0.0) || !(wo.z > 0.0)) return glm::dvec3(0.0);
  const glm::dvec3 h = glm::normalize(wi + wo);
  // sin and cos of theta_h and phi_h from h itself (no angles): the same
  // values as the reference's arccos and atan2 up to rounding, with
  // atan2(0, 0) = 0 where h = n.
  const double sin_theta = std::hypot(h.x, h.y), cos_theta = h.z;
  const double cos_phi = sin_theta > 0.0 ? h.x / sin_theta : 1.0;
  const double sin_phi = sin_theta > 0.0 ? h.y / sin_theta : 0.0;
  // u = Rz(-phi_h) wi, d = Ry(-theta_h) u.
  const glm::dvec3 u(cos_phi * wi.x + sin_phi * wi.y, -sin_phi * wi.x + cos_phi * wi.y, wi.z);
  const glm::dvec3 d =
      glm::normalize(glm::dvec3(cos_theta * u.x - sin_theta * u.z, u.y, sin_theta * u.x + cos_theta * u.z));

  const double x[kInputs] = {sin_theta, 0.0, cos_theta, d.x, d.y, d.z};
  double a1[kHidden], a2[kHidden], a3[kOutputs];
  const double* w = weights_.data();
  Dense<kInputs, kHidden>(w + kW1, w + kB1, x, a1);
  for (double& a : a1) a = std::max(a, 0.0);
  Dense<kHidden, kHidden>(w + kW2, w + kB2, a1, a2);
  for (double& a : a2) a = std::max(a, 0.0);
  Dense<kHidden, kOutputs>(w + kW3, w + kB3, a2, a3);
  // exp(a) - 1, exactly rounded also where it is small.
  return glm::dvec3(std::max(std::expm1(a3[0]), 0.0), std::max(std::expm1(a3[1]), 0.0),
                    std::max(std::expm1(a3[2]), 0.0));
}

glm::dvec3 NeuralBrdf::EvaluateWorld(const glm::dvec3& n, const glm::dvec3& l, const glm::dvec3& v) const {
  glm::dvec3 t, b;
  TangentFrame(n, &t, &b);
  return Evaluate(glm::dvec3(glm::dot(l, t), glm::dot(l, b), glm::dot(l, n)),
                  glm::dvec3(glm::dot(v, t), glm::dot(v, b), glm::dot(v, n)));
}

std::vector<float> NeuralBrdf::GlslWeights() const { return std::vector<float>(weights_.begin(), weights_.end()); }

absl::StatusOr<std::map<std::string, NeuralBrdf>> LoadNeuralBrdfs(const std::filesystem::path& json) {
  MVBRDF_ASSIGN_OR_RETURN(const Struct materials, ReadMaterials(json));
  std::map<std::string, NeuralBrdf> out;
  for (const auto& [name, value] : materials.fields()) {
    MVBRDF_ASSIGN_OR_RETURN(NeuralBrdf brdf, ReadMaterial(value, json.string(), name));
    out.emplace(name, std::move(brdf));
  }
  return out;
}

absl::StatusOr<NeuralBrdf> LoadNeuralBrdf(const std::filesystem::path& json, absl::string_view name) {
  MVBRDF_ASSIGN_OR_RETURN(const Struct materials, ReadMaterials(json));
  const auto found = materials.fields().find(std::string(name));
  if (found == materials.fields().end()) {
    // Names holding the one asked for first ("chrom": chrome, chrome-steel),
    // then the rest, each group in alphabetical order.
    std::vector<std::string> names;
    for (const auto& [known, unused] : materials.fields()) names.push_back(known);
    std::sort(names.begin(), names.end());
    std::stable_partition(names.begin(), names.end(),
                          [&](const std::string& known) { return absl::StrContains(known, name); });
    const size_t total = names.size();
    if (names.size() > kNamesShown) names.resize(kNamesShown);
    return absl::NotFoundError(absl::StrCat(json.string(), ": materials: no material \"", name, "\" (", total,
                                            " materials: ", absl::StrJoin(names, ", "),
                                            total > names.size() ? ", ..." : "", ")"));
  }
  return ReadMaterial(found->second, json.string(), name);
}

}  // namespace mvbrdf::brdf
