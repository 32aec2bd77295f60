#include "core/scene/scene_fix.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/scene/sequence.h"

namespace mvbrdf::scene {
namespace {

// A rotation about (1, 2, 2)/3 by 0.7 rad, exact to double rounding.
std::array<double, 9> TrueRotation() {
  const double x = 1.0 / 3, y = 2.0 / 3, z = 2.0 / 3, c = std::cos(0.7), s = std::sin(0.7);
  return {c + x * x * (1 - c),     x * y * (1 - c) - z * s, x * z * (1 - c) + y * s,
          y * x * (1 - c) + z * s, c + y * y * (1 - c),     y * z * (1 - c) - x * s,
          z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, c + z * z * (1 - c)};
}

v1::Scene SceneWith(const std::array<double, 9>& rotation) {
  v1::Scene scene;
  v1::Camera* camera = scene.add_cameras();
  camera->set_name("cam0");
  camera->set_width(64);
  camera->set_height(48);
  camera->mutable_intrinsics()->set_fx(50);
  camera->mutable_intrinsics()->set_fy(50);
  for (double v : rotation) camera->mutable_cam_from_world()->add_rotation(v);
  for (int i = 0; i < 3; ++i) camera->mutable_cam_from_world()->add_translation(0);
  return scene;
}

// Five decimals: off by up to 5e-6 per entry (six are just under validation's
// 1e-6 for this rotation; the CLI test rounds the synthetic cameras to six).
TEST(FixRounding, RotationRoundedToFiveDecimals) {
  const std::array<double, 9> truth = TrueRotation();
  std::array<double, 9> rounded;
  for (int i = 0; i < 9; ++i) rounded[i] = std::round(truth[i] * 1e5) / 1e5;
  v1::Scene scene = SceneWith(rounded);
  // Refused as it is ...
  const absl::Status before = ValidateCameraGeometry(scene.cameras(0), "scene.cameras[0]");
  ASSERT_FALSE(before.ok());
  EXPECT_NE(std::string(before.message()).find("max |R*R^T - I|"), std::string::npos) << before;
  std::vector<std::string> changes;
  ASSERT_TRUE(FixRounding(&scene, &changes).ok());
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_NE(changes[0].find("camera cam0: rotation made orthonormal (max |R*R^T - I| was"), std::string::npos)
      << changes[0];
  // ... valid after, and within the rounding of the truth.
  EXPECT_TRUE(ValidateCameraGeometry(scene.cameras(0), "scene.cameras[0]").ok());
  double worst = 0;
  for (int i = 0; i < 9; ++i)
    worst = std::max(worst, std::abs(scene.cameras(0).cam_from_world().rotation(i) - truth[i]));
  EXPECT_LT(worst, 1e-5);
  // A second fix leaves the rotation as it is (orthonormal to double rounding).
  const v1::Scene fixed = scene;
  std::vector<std::string> again;
  ASSERT_TRUE(FixRounding(&scene, &again).ok());
  EXPECT_TRUE(again.empty());
  for (int i = 0; i < 9; ++i)
    EXPECT_EQ(scene.cameras(0).cam_from_world().rotation(i), fixed.cameras(0).cam_from_world().rotation(i));
}

TEST(FixRounding, RefusesWhatIsNotRounding) {
  std::array<double, 9> reflection = TrueRotation();
  for (int i = 0; i < 3; ++i) reflection[i] = -reflection[i];
  std::array<double, 9> scaled = TrueRotation();
  for (double& v : scaled) v *= 1.01;
  for (const auto& [rotation, expected] : std::vector<std::pair<std::array<double, 9>, std::string>>{
           {reflection, "scene.cameras[0].cam_from_world.rotation (camera \"cam0\"): determinant -1 < 0"},
           {scaled, "scene.cameras[0].cam_from_world.rotation (camera \"cam0\"): max |R*R^T - I| is 0.02, too far"}}) {
    v1::Scene scene = SceneWith(rotation);
    std::vector<std::string> changes;
    const absl::Status s = FixRounding(&scene, &changes);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(std::string(s.message()).find(expected), std::string::npos) << s;
  }
}

TEST(FixRounding, LightDirections) {
  v1::Scene scene = SceneWith(TrueRotation());
  v1::Light* light = scene.add_lights();
  light->set_name("sun");
  for (double v : {0.0, 2.0, 0.0}) light->add_direction(v);
  v1::Light* point = scene.add_lights();
  point->set_name("bulb");
  for (double v : {0.0, 2.0, 0.0}) point->add_position(v);
  std::vector<std::string> changes;
  ASSERT_TRUE(FixRounding(&scene, &changes).ok());
  EXPECT_EQ(scene.lights(0).direction(1), 1.0);
  EXPECT_EQ(scene.lights(1).position(1), 2.0);  // a position is not a direction
  EXPECT_NE(changes.back().find("light sun: direction renormalised (length was 2)"), std::string::npos);
  scene.mutable_lights(0)->mutable_direction()->Set(1, 0.0);
  const absl::Status s = FixRounding(&scene, &changes);
  EXPECT_NE(std::string(s.message()).find("scene.lights[0].direction (light \"sun\"): has zero length"),
            std::string::npos)
      << s;
}

}  // namespace
}  // namespace mvbrdf::scene
