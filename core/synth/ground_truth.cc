#include "core/synth/ground_truth.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <tuple>

#include "absl/strings/str_cat.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/scene/video_source.h"

namespace mvbrdf::synth {
namespace {

glm::vec3 Vec3(const google::protobuf::RepeatedField<double>& v, const glm::vec3& fallback) {
  if (v.size() != 3) return fallback;
  return {static_cast<float>(v.Get(0)), static_cast<float>(v.Get(1)), static_cast<float>(v.Get(2))};
}

render::SolidTextureParams SolidTexture(const v1::SolidTexture& t) {
  render::SolidTextureParams p;
  p.base = Vec3(t.base(), glm::vec3(0.5f));
  p.amplitude = static_cast<float>(t.amplitude());
  p.frequency = static_cast<float>(t.frequency());
  p.offset = Vec3(t.offset(), glm::vec3(0.0f));
  return p;
}

// Bilinear lookup with clamp-to-edge, like the renderer's GL_LINEAR sampler:
// texel (i, j) has its centre at u = (i + 0.5) / W, v = 1 - (j + 0.5) / H.
glm::vec3 SampleBilinear(const cv::Mat& image, const glm::vec2& uv) {
  const float x = uv.x * static_cast<float>(image.cols) - 0.5f;
  const float y = (1.0f - uv.y) * static_cast<float>(image.rows) - 0.5f;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
  const auto at = [&](int xi, int yi) {
    const cv::Vec3f& v = image.at<cv::Vec3f>(std::clamp(yi, 0, image.rows - 1), std::clamp(xi, 0, image.cols - 1));
    return glm::vec3(v[0], v[1], v[2]);
  };
  return (1.0f - fy) * ((1.0f - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
         fy * ((1.0f - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
}

}  // namespace

absl::StatusOr<GroundTruth> GroundTruth::Load(const std::filesystem::path& truth_file) {
  GroundTruth gt;
  MVBRDF_ASSIGN_OR_RETURN(gt.truth_, ReadJsonFileAs<v1::GroundTruth>(truth_file));
  if (gt.truth_.materials_size() == 0) {
    return absl::InvalidArgumentError(absl::StrCat(truth_file.string(), ": materials: expected at least one"));
  }
  for (uint32_t m : gt.truth_.triangle_materials()) {
    if (m >= static_cast<uint32_t>(gt.truth_.materials_size())) {
      return absl::InvalidArgumentError(absl::StrCat(truth_file.string(), ": triangle_materials: material ", m,
                                                     " out of range"));
    }
  }
  for (const v1::Material& m : gt.truth_.materials()) {
    if (m.measured().empty()) {
      gt.measured_index_.push_back(-1);
      continue;
    }
    if (m.measured_weights_size() != brdf::NeuralBrdf::kNumWeights) {
      return absl::InvalidArgumentError(absl::StrCat(truth_file.string(), ": materials \"", m.name(),
                                                     "\": measured_weights: expected ", brdf::NeuralBrdf::kNumWeights,
                                                     " (a 6-21-21-3 network), got ", m.measured_weights_size()));
    }
    std::array<double, brdf::NeuralBrdf::kNumWeights> w{};
    for (int i = 0; i < brdf::NeuralBrdf::kNumWeights; ++i) w[static_cast<size_t>(i)] = m.measured_weights(i);
    gt.measured_index_.push_back(static_cast<int>(gt.measured_.size()));
    gt.measured_.emplace_back(w);
  }
  for (const v1::Material& m : gt.truth_.materials()) {
    if (m.kd_texture_path().empty()) continue;
    const auto file = truth_file.parent_path() / m.kd_texture_path();
    MVBRDF_ASSIGN_OR_RETURN(gt.kd_texture_, scene::ReadLinearRgbImage(file, /*srgb=*/true));
  }
  return gt;
}

render::PhongParams GroundTruth::At(uint32_t triangle, const glm::vec3& rest_position, const glm::vec2& uv) const {
  const uint32_t index = triangle < static_cast<uint32_t>(truth_.triangle_materials_size())
                             ? truth_.triangle_materials(static_cast<int>(triangle))
                             : 0u;
  const v1::Material& m = truth_.materials(static_cast<int>(index));
  render::PhongParams p;
  p.kd = !m.kd_texture_path().empty() && !kd_texture_.empty()
             ? SampleBilinear(kd_texture_, uv)
             : render::EvaluateSolidTexture(SolidTexture(m.kd()), rest_position);
  const auto [p0, p1] = Parameters(m);
  p.ks = p0;
  p.ke = p1;
  return p;
}

std::vector<scene::Light> GroundTruth::ActiveLights() const {
  std::vector<scene::Light> lights;
  for (const v1::Light& l : truth_.lights()) {
    scene::Light light;
    light.name = l.name();
    light.directional = l.direction_size() == 3;
    light.position = Vec3(l.position(), glm::vec3(0.0f));
    if (light.directional) light.direction = glm::normalize(Vec3(l.direction(), glm::vec3(0, 1, 0)));
    light.intensity = Vec3(l.intensity(), glm::vec3(1.0f));
    lights.push_back(light);
  }
  return lights;
}

std::vector<scene::Light> GroundTruth::FrameLights(uint32_t frame) const {
  std::vector<scene::Light> all = ActiveLights();
  for (const v1::FrameLighting& fl : truth_.frame_lighting()) {
    if (fl.frame() != frame) continue;
    std::vector<scene::Light> on;
    for (const std::string& name : fl.lights()) {
      for (const scene::Light& l : all) {
        if (l.name == name) on.push_back(l);
      }
    }
    return on;
  }
  return all;
}

std::vector<scene::CameraModel> GroundTruth::Cameras() const {
  std::vector<scene::CameraModel> cameras;
  for (const v1::Camera& c : truth_.cameras()) cameras.push_back(scene::CameraModelFromProto(c));
  return cameras;
}

brdf::Model GroundTruth::Model() const {
  auto model = brdf::ParseModel(truth_.brdf());
  return truth_.brdf().empty() || !model.ok() ? brdf::Model::kPhong : *model;
}

std::pair<glm::vec3, glm::vec3> GroundTruth::Parameters(const v1::Material& m) const {
  if (Model() == brdf::Model::kGgx) return {Vec3(m.f0(), glm::vec3(0.0f)), Vec3(m.roughness(), glm::vec3(1.0f))};
  return {Vec3(m.ks(), glm::vec3(0.0f)), Vec3(m.ke(), glm::vec3(1.0f))};
}

bool GroundTruth::IsMeasured(int index) const {
  return index >= 0 && static_cast<size_t>(index) < measured_index_.size() &&
         measured_index_[static_cast<size_t>(index)] >= 0;
}

std::vector<render::ProceduralMaterial> GroundTruth::RendererMaterials() const {
  std::vector<render::ProceduralMaterial> out;
  for (const v1::Material& m : truth_.materials()) {
    render::ProceduralMaterial pm;
    if (out.size() < measured_index_.size()) pm.measured = measured_index_[out.size()];
    pm.measured_gain = m.measured_gain() > 0.0 ? static_cast<float>(m.measured_gain()) : 1.0f;
    pm.kd = SolidTexture(m.kd());
    pm.kd_from_texture = !m.kd_texture_path().empty();
    std::tie(pm.ks, pm.ke) = Parameters(m);
    out.push_back(pm);
  }
  return out;
}

render::NormalDetail GroundTruth::Detail() const {
  render::NormalDetail detail;
  if (!truth_.has_normal_detail()) return detail;
  const v1::NormalDetail& d = truth_.normal_detail();
  detail.amplitude = static_cast<float>(d.amplitude());
  detail.wavelength = static_cast<float>(d.wavelength());
  if (d.d1_size() == 3 && d.d2_size() == 3) {
    detail.d1 = glm::vec3(d.d1(0), d.d1(1), d.d1(2));
    detail.d2 = glm::vec3(d.d2(0), d.d2(1), d.d2(2));
  }
  return detail;
}

}  // namespace mvbrdf::synth
