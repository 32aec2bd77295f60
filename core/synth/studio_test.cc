#include "core/synth/studio.h"

#include <gtest/gtest.h>

namespace mvbrdf::synth {
namespace {

constexpr double kPixelTolerance = 1e-4;  // the subject bounds are float

TEST(StudioTest, CamerasOnARingLookAtTheSubject) {
  StudioOptions options;
  const SubjectBounds subject{{-0.3f, 0.0f, -0.2f}, {0.3f, 1.8f, 0.2f}};
  const Studio studio = MakeStudio(options, subject);
  ASSERT_EQ(studio.cameras.size(), 8u);
  const glm::dvec3 center(0.0, 0.9, 0.0);  // the cameras aim at the subject's centre
  for (const auto& cam : studio.cameras) {
    const glm::dvec2 px = cam.Project(center);
    EXPECT_NEAR(px.x, cam.cx, kPixelTolerance) << cam.name;
    EXPECT_NEAR(px.y, cam.cy, kPixelTolerance) << cam.name;
    // The subject's top and feet are inside the frame.
    const glm::dvec2 top = cam.Project({0.0, 1.8, 0.0});
    const glm::dvec2 feet = cam.Project({0.0, 0.0, 0.0});
    EXPECT_GT(top.y, 0.0);
    EXPECT_LT(feet.y, cam.height - 1.0);
    EXPECT_LT(top.y, feet.y);  // y down: up in the world is up in the image
    // Rotation is orthonormal.
    const glm::dmat3 rtr = glm::transpose(cam.cam_from_world_rotation) * cam.cam_from_world_rotation;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) EXPECT_NEAR(rtr[i][j], i == j ? 1.0 : 0.0, 1e-12);
    EXPECT_NEAR(glm::determinant(cam.cam_from_world_rotation), 1.0, 1e-12);
  }
  // World +x appears to the right for a camera looking along -z (camera 0 sits at +z).
  const auto& cam0 = studio.cameras[0];
  EXPECT_GT(cam0.CenterInWorld().z, 1.0);
  EXPECT_GT(cam0.Project({0.2, 0.9, 0.0}).x, cam0.Project({-0.2, 0.9, 0.0}).x);
}

TEST(StudioTest, NineCeilingLightsAndTheThesisConfigurations) {
  const Studio studio = MakeStudio({}, {{-0.3f, 0.0f, -0.2f}, {0.3f, 1.8f, 0.2f}});
  ASSERT_EQ(studio.lights.size(), 9u);
  for (const auto& l : studio.lights) EXPECT_GT(l.position.y, 1.8f) << l.name;
  ASSERT_EQ(studio.configurations.size(), 8u);
  EXPECT_EQ(studio.configurations[2].name, "NE,NW,SE,SW");
  EXPECT_EQ(studio.configurations[7].lights.size(), 9u);
  // North is -z, east is +x.
  const auto find = [&](const std::string& n) {
    for (const auto& l : studio.lights)
      if (l.name == n) return l.position;
    return glm::vec3(0.0f);
  };
  EXPECT_LT(find("N").z, find("C").z);
  EXPECT_GT(find("E").x, find("C").x);
}

TEST(StudioTest, MaterialsUseTheThesisSeeds) {
  const auto m = StudioMaterials();
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0].name, "cloth");
  EXPECT_EQ(m[0].seed_srgb8, glm::ivec3(144, 71, 72));
  EXPECT_EQ(m[1].seed_srgb8, glm::ivec3(160, 135, 109));
  EXPECT_EQ(m[2].seed_srgb8, glm::ivec3(76, 74, 67));
  // kd is the linearised seed: sRGB 144 -> 0.2789 linear.
  EXPECT_NEAR(m[0].kd.base.x, 0.2789f, 1e-3f);
}

}  // namespace
}  // namespace mvbrdf::synth
