#include "core/synth/ground_truth.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "core/base/files.h"
#include "core/base/proto_json.h"
#include "core/scene/video_source.h"
#include "core/synth/studio.h"

namespace mvbrdf::synth {
namespace {

constexpr float kExact = 1e-6f;

std::filesystem::path Dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("mvbrdf_ground_truth_test_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// Two triangles: triangle 0 is cloth (solid texture), triangle 1 uses a 2x2
// kd texture.
v1::GroundTruth TwoMaterials() {
  v1::GroundTruth truth;
  const auto studio = StudioMaterials();
  v1::Material* cloth = truth.add_materials();
  cloth->set_name("cloth");
  for (int i = 0; i < 3; ++i) cloth->mutable_kd()->add_base(studio[0].kd.base[i]);
  cloth->mutable_kd()->set_amplitude(studio[0].kd.amplitude);
  cloth->mutable_kd()->set_frequency(studio[0].kd.frequency);
  for (int i = 0; i < 3; ++i) cloth->mutable_kd()->add_offset(0.0);
  for (int i = 0; i < 3; ++i) cloth->add_ks(0.04);
  for (int i = 0; i < 3; ++i) cloth->add_ke(4.0);
  v1::Material* textured = truth.add_materials();
  textured->set_name("textured");
  textured->set_kd_texture_path("kd.png");
  for (int i = 0; i < 3; ++i) textured->add_ks(0.1 * (i + 1));
  for (int i = 0; i < 3; ++i) textured->add_ke(12.0);
  truth.add_triangle_materials(0);
  truth.add_triangle_materials(1);
  v1::Light* light = truth.add_lights();
  light->set_name("NE");
  for (double p : {1.0, 3.0, -1.0}) light->add_position(p);
  for (double p : {0.6, 0.5, 0.4}) light->add_intensity(p);
  return truth;
}

TEST(GroundTruthTest, EvaluatesSolidAndImageTextures) {
  const auto dir = Dir("eval");
  ASSERT_TRUE(WriteJsonFile(dir / "truth.json", TwoMaterials()).ok());
  // 2x2 sRGB texture: top-left red (255,0,0), top-right (0,128,0), bottom row grey 128.
  cv::Mat bgr(2, 2, CV_8UC3);
  bgr.at<cv::Vec3b>(0, 0) = {0, 0, 255};
  bgr.at<cv::Vec3b>(0, 1) = {0, 128, 0};
  bgr.at<cv::Vec3b>(1, 0) = {128, 128, 128};
  bgr.at<cv::Vec3b>(1, 1) = {128, 128, 128};
  ASSERT_TRUE(cv::imwrite((dir / "kd.png").string(), bgr));
  auto truth = GroundTruth::Load(dir / "truth.json");
  ASSERT_TRUE(truth.ok()) << truth.status();

  const glm::vec3 p(0.3f, 1.1f, -0.2f);
  const render::PhongParams cloth = truth->At(0, p, {0.0f, 0.0f});
  const glm::vec3 expected = render::EvaluateSolidTexture(StudioMaterials()[0].kd, p);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(cloth.kd[c], expected[c], kExact);
  EXPECT_NEAR(cloth.ks.x, 0.04f, kExact);
  EXPECT_NEAR(cloth.ke.z, 4.0f, kExact);

  // Texel centres: (u, v) = (0.25, 0.75) is the top-left texel (row 0 = v near 1).
  const render::PhongParams red = truth->At(1, p, {0.25f, 0.75f});
  EXPECT_NEAR(red.kd.x, 1.0f, kExact);
  EXPECT_NEAR(red.kd.y, 0.0f, kExact);
  const render::PhongParams green = truth->At(1, p, {0.75f, 0.75f});
  EXPECT_NEAR(green.kd.y, scene::SrgbToLinear(128.0f / 255.0f), kExact);
  // Half-way between the top texels: the bilinear mean.
  const render::PhongParams mid = truth->At(1, p, {0.5f, 0.75f});
  EXPECT_NEAR(mid.kd.x, 0.5f, kExact);
  EXPECT_NEAR(red.ks.z, 0.3f, kExact);

  const auto lights = truth->ActiveLights();
  ASSERT_EQ(lights.size(), 1u);
  EXPECT_EQ(lights[0].position, glm::vec3(1.0f, 3.0f, -1.0f));
  EXPECT_NEAR(lights[0].intensity.z, 0.4f, kExact);
  const auto materials = truth->RendererMaterials();
  ASSERT_EQ(materials.size(), 2u);
  EXPECT_FALSE(materials[0].kd_from_texture);
  EXPECT_TRUE(materials[1].kd_from_texture);
}

// Issue #13: a frame with a frame_lighting entry is lit by its lights (by
// name among the truth's), any other frame by every light.
TEST(GroundTruthTest, FrameLightsAreTheFramesOwnElseAll) {
  const auto dir = Dir("frame_lights");
  v1::GroundTruth message = TwoMaterials();
  message.mutable_materials(1)->clear_kd_texture_path();  // no texture file needed here
  v1::Light* second = message.add_lights();
  second->set_name("SW");
  for (double p : {-1.0, 3.0, 1.0}) second->add_position(p);
  v1::FrameLighting* fl = message.add_frame_lighting();
  fl->set_frame(4);
  fl->add_lights("SW");
  message.add_frame_lighting()->set_frame(5);  // dark
  ASSERT_TRUE(WriteJsonFile(dir / "truth.json", message).ok());
  auto truth = GroundTruth::Load(dir / "truth.json");
  ASSERT_TRUE(truth.ok()) << truth.status();
  const auto own = truth->FrameLights(4);
  ASSERT_EQ(own.size(), 1u);
  EXPECT_EQ(own[0].name, "SW");
  EXPECT_EQ(own[0].position, glm::vec3(-1.0f, 3.0f, 1.0f));
  EXPECT_TRUE(truth->FrameLights(5).empty());
  EXPECT_EQ(truth->FrameLights(0).size(), 2u);
}

TEST(GroundTruthTest, BadFilesAreErrorsNamingThem) {
  const auto dir = Dir("bad");
  EXPECT_EQ(GroundTruth::Load(dir / "missing.json").status().code(), absl::StatusCode::kNotFound);
  v1::GroundTruth truth = TwoMaterials();
  ASSERT_TRUE(WriteJsonFile(dir / "truth.json", truth).ok());
  const absl::Status no_texture = GroundTruth::Load(dir / "truth.json").status();
  EXPECT_NE(no_texture.message().find("kd.png"), std::string::npos) << no_texture;
  truth.add_triangle_materials(7);
  truth.mutable_materials(1)->clear_kd_texture_path();
  ASSERT_TRUE(WriteJsonFile(dir / "truth.json", truth).ok());
  const absl::Status out_of_range = GroundTruth::Load(dir / "truth.json").status();
  EXPECT_NE(out_of_range.message().find("triangle_materials"), std::string::npos) << out_of_range;
}

}  // namespace
}  // namespace mvbrdf::synth
