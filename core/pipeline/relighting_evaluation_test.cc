#include "core/pipeline/relighting_evaluation.h"

#include <gtest/gtest.h>

#include <cmath>

namespace mvbrdf::pipeline {
namespace {

// A camera at `centre` looking at the origin, world +y up (OpenCV axes:
// x right, y down, z forward).
scene::CameraModel LookAtOrigin(const std::string& name, const glm::dvec3& centre) {
  scene::CameraModel c;
  c.name = name;
  c.width = 64;
  c.height = 48;
  c.fx = c.fy = 60.0;
  c.cx = 31.5;
  c.cy = 23.5;
  c.distortion[0] = -0.1;
  const glm::dvec3 z = glm::normalize(-centre);
  const glm::dvec3 x = glm::normalize(glm::cross(z, glm::dvec3(0.0, -1.0, 0.0)));
  const glm::dvec3 y = glm::cross(z, x);
  // Rows x, y, z (glm is column-major: m[col][row]).
  c.cam_from_world_rotation = glm::transpose(glm::dmat3(x, y, z));
  c.cam_from_world_translation = -(c.cam_from_world_rotation * centre);
  return c;
}

TEST(RelightingEvaluationTest, HeldOutViewsLieHalfWayBetweenCamerasAndLookAtTheSubject) {
  scene::Sequence sequence;
  sequence.cameras = {LookAtOrigin("a", {3.0, 1.0, 0.0}), LookAtOrigin("b", {0.0, 1.0, 3.0}),
                      LookAtOrigin("c", {-3.0, 1.0, 0.0}), LookAtOrigin("d", {0.0, 1.0, -3.0})};
  const std::vector<glm::vec3> pose = {{-0.5f, -0.5f, -0.5f}, {0.5f, 0.5f, 0.5f}};  // centred on the origin
  const std::vector<scene::CameraModel> views = HeldOutViews(sequence, pose, 2);
  ASSERT_EQ(views.size(), 2u);
  EXPECT_EQ(views[0].name, "between a and b");
  EXPECT_EQ(views[1].name, "between c and d");
  const double r = 3.0 / std::sqrt(2.0);
  const glm::dvec3 expected[2] = {{r, 1.0, r}, {-r, 1.0, -r}};
  for (int i = 0; i < 2; ++i) {
    const glm::dvec3 c = views[static_cast<size_t>(i)].CenterInWorld();
    EXPECT_NEAR(glm::length(c - expected[i]), 0.0, 1e-9) << i;
    // The origin projects where it did for the source camera, at the same depth.
    const glm::dvec3 o = views[static_cast<size_t>(i)].CamFromWorld(glm::dvec3(0.0));
    EXPECT_NEAR(o.x, 0.0, 1e-9);
    EXPECT_NEAR(o.y, 0.0, 1e-9);
    EXPECT_NEAR(o.z, std::sqrt(10.0), 1e-9);
    EXPECT_EQ(views[static_cast<size_t>(i)].distortion[0], 0.0);  // drawn without a lens
  }
}

TEST(RelightingEvaluationTest, HeldOutLightsAreTheUnusedCandidatesElseTheCapturesTurned) {
  scene::Sequence sequence;
  sequence.cameras = {LookAtOrigin("a", {3.0, 1.0, 0.0}), LookAtOrigin("b", {0.0, 1.0, 3.0})};
  const auto light = [](const std::string& name, const glm::vec3& p) {
    scene::Light l;
    l.name = name;
    l.position = p;
    return l;
  };
  sequence.lights = {light("N", {0, 3, 2}), light("S", {0, 3, -2}), light("E", {2, 3, 0}), light("W", {-2, 3, 0})};
  const std::vector<glm::vec3> pose = {{-0.5f, -0.5f, -0.5f}, {0.5f, 0.5f, 0.5f}};
  const std::vector<scene::Light> unused = HeldOutLights(sequence, {sequence.lights[0], sequence.lights[2]}, pose, 3);
  ASSERT_EQ(unused.size(), 2u);
  EXPECT_EQ(unused[0].name, "S");
  EXPECT_EQ(unused[1].name, "W");
  const std::vector<scene::Light> turned = HeldOutLights(sequence, sequence.lights, pose, 1);
  ASSERT_EQ(turned.size(), 1u);
  EXPECT_EQ(turned[0].name, "N turned 45 deg");
  // Turned about the vertical axis through the subject: same height and distance.
  EXPECT_NEAR(turned[0].position.y, 3.0f, 1e-5f);
  EXPECT_NEAR(glm::length(glm::vec2(turned[0].position.x, turned[0].position.z)), 2.0f, 1e-5f);
  EXPECT_NEAR(std::abs(turned[0].position.x), std::sqrt(2.0f), 1e-5f);
}

}  // namespace
}  // namespace mvbrdf::pipeline
