// Reads what `mvbrdf synth` recorded (ground_truth/truth.json) and evaluates
// it: the true parameters at any surface point, the active lights and
// the cameras as rendered. Later stages check their outputs against this,
// never against their own.
#ifndef MVBRDF_CORE_SYNTH_GROUND_TRUTH_H_
#define MVBRDF_CORE_SYNTH_GROUND_TRUTH_H_

#include <filesystem>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "core/brdf/model.h"
#include "core/brdf/nbrdf.h"
#include "core/render/phong_model.h"
#include "core/render/normal_detail.h"
#include "core/render/phong_renderer.h"
#include "core/scene/camera_model.h"
#include "core/scene/light.h"
#include "mvbrdf/v1/ground_truth.pb.h"

namespace mvbrdf::synth {

class GroundTruth {
 public:
  // `truth_file` is a bundle's ground_truth/truth.json; a kd texture it names
  // is read from beside it.
  static absl::StatusOr<GroundTruth> Load(const std::filesystem::path& truth_file);

  const v1::GroundTruth& message() const { return truth_; }

  // The model the truth was rendered with (truth.json's brdf; Phong when
  // empty): At's and RendererMaterials' ks and ke hold its two parameters
  // (brdf::ParameterNames), as the renderer takes them.
  brdf::Model Model() const;
  // A material's two parameters in the model's terms.
  std::pair<glm::vec3, glm::vec3> Parameters(const v1::Material& material) const;

  // True parameters at a surface point of triangle `triangle` (file order):
  // `rest_position` is the point in the rest pose (frame 0, world units),
  // `uv` its texture coordinate (used only by materials with a kd texture).
  render::PhongParams At(uint32_t triangle, const glm::vec3& rest_position, const glm::vec2& uv) const;

  // The surface detail rendered (issue #18; amplitude 0: none).
  render::NormalDetail Detail() const;

  // The lights that lit every frame, with their true positions and intensities
  // (with per-frame lighting: every light that lit some frame).
  std::vector<scene::Light> ActiveLights() const;
  // The lights that lit absolute frame `frame`: its frame_lighting entry's
  // (by name among ActiveLights), else ActiveLights.
  std::vector<scene::Light> FrameLights(uint32_t frame) const;
  // The cameras as rendered (before any calibration error).
  std::vector<scene::CameraModel> Cameras() const;
  // The materials in the renderer's form (kd texture: see KdTexture();
  // measured materials index MeasuredBrdfs(), to give the renderer first).
  std::vector<render::ProceduralMaterial> RendererMaterials() const;
  // Whether material `index` is a measured one (v1::Material::measured):
  // it has no analytic parameters and no kd to compare with.
  bool IsMeasured(int index) const;
  // The measured materials' networks, in material order (those RendererMaterials' measured indices name).
  const std::vector<brdf::NeuralBrdf>& MeasuredBrdfs() const { return measured_; }
  // Linear RGB CV_32FC3 kd texture (row 0 = v = 1), empty when none.
  const cv::Mat& KdTexture() const { return kd_texture_; }

 private:
  v1::GroundTruth truth_;
  cv::Mat kd_texture_;
  std::vector<brdf::NeuralBrdf> measured_;
  std::vector<int> measured_index_;  // per material: its index in measured_, or -1
};

}  // namespace mvbrdf::synth

#endif  // MVBRDF_CORE_SYNTH_GROUND_TRUTH_H_
