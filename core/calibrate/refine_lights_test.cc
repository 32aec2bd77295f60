// ApplyLightRefinement and CopyLightRefinement; RefineLights itself is
// checked end to end against the truth (tests/cli_light_refinement_test.sh).
#include "core/calibrate/refine_lights.h"

#include <gtest/gtest.h>

namespace mvbrdf::calibrate {
namespace {

scene::Sequence TwoLights() {
  scene::Sequence s;
  for (const char* name : {"A", "B"}) {
    scene::Light l;
    l.name = name;
    l.position = glm::vec3(1.0f, 2.0f, 3.0f);
    s.lights.push_back(l);
    v1::Light* p = s.scene.add_lights();
    p->set_name(name);
    for (double v : {1.0, 2.0, 3.0}) p->add_position(v);
  }
  return s;
}

v1::CalibrationReport Refined(const std::string& name) {
  v1::CalibrationReport r;
  r.set_lights_refined(true);
  v1::LightRefinementRow* row = r.add_lights();
  row->set_name(name);
  row->mutable_light()->set_name(name);
  for (double v : {4.0, 5.0, 6.0}) row->mutable_light()->add_position(v);
  for (double v : {0.5, 0.5, 0.5}) row->mutable_light()->add_intensity(v);
  return r;
}

TEST(ApplyLightRefinementTest, UsesTheRefinedLightsOnlyWhenRefined) {
  scene::Sequence s = TwoLights();
  v1::CalibrationReport r = Refined("B");
  r.set_lights_refined(false);
  ASSERT_TRUE(ApplyLightRefinement(r, &s).ok());
  EXPECT_EQ(s.lights[1].position, glm::vec3(1.0f, 2.0f, 3.0f));
  r.set_lights_refined(true);
  ASSERT_TRUE(ApplyLightRefinement(r, &s).ok());
  EXPECT_EQ(s.lights[0].position, glm::vec3(1.0f, 2.0f, 3.0f));
  EXPECT_EQ(s.lights[1].position, glm::vec3(4.0f, 5.0f, 6.0f));
  EXPECT_EQ(s.lights[1].intensity, glm::vec3(0.5f));
  EXPECT_EQ(s.scene.lights(1).position(2), 6.0);
  EXPECT_EQ(s.scene.lights(1).intensity(0), 0.5);
}

TEST(ApplyLightRefinementTest, NamesAnUnknownLightOrABadField) {
  scene::Sequence s = TwoLights();
  absl::Status st = ApplyLightRefinement(Refined("C"), &s);
  EXPECT_EQ(st.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(st.message().find("\"C\" is no light of the scene"), std::string::npos) << st;
  v1::CalibrationReport r = Refined("A");
  r.mutable_lights(0)->mutable_light()->clear_intensity();
  st = ApplyLightRefinement(r, &s);
  EXPECT_NE(st.message().find("calibration.lights[A].light.intensity: expected 3 finite values"), std::string::npos)
      << st;
}

TEST(CopyLightRefinementTest, KeepsTheCameras) {
  v1::CalibrationReport from = Refined("A"), to;
  from.set_lights_decision("why");
  to.set_cameras_refined(true);
  CopyLightRefinement(from, &to);
  EXPECT_TRUE(to.cameras_refined());
  EXPECT_TRUE(to.lights_refined());
  EXPECT_EQ(to.lights_decision(), "why");
  EXPECT_EQ(to.lights_size(), 1);
}

}  // namespace
}  // namespace mvbrdf::calibrate
