#include "core/base/proto_json.h"

#include <gtest/gtest.h>
#include <google/protobuf/util/message_differencer.h>

#include "mvbrdf/v1/scene.pb.h"

namespace mvbrdf {
namespace {

v1::Scene MakeScene() {
  v1::Scene scene;
  scene.set_name("round-trip");
  scene.mutable_mesh()->set_path("mesh_%04d.obj");
  scene.mutable_frames()->set_count(10);
  scene.mutable_frames()->set_fps(15);
  auto* cam = scene.add_cameras();
  cam->set_name("cam0");
  cam->set_width(320);
  cam->set_height(240);
  cam->mutable_intrinsics()->set_fx(300);
  cam->mutable_intrinsics()->set_fy(300.5);
  cam->mutable_intrinsics()->set_cx(159.5);
  cam->mutable_intrinsics()->set_cy(119.5);
  for (double d : {0.01, -0.002, 0.0, 0.0}) cam->mutable_intrinsics()->add_distortion(d);
  for (double r : {1, 0, 0, 0, 1, 0, 0, 0, 1}) cam->mutable_cam_from_world()->add_rotation(r);
  for (double t : {0.0, -1.0, 3.5}) cam->mutable_cam_from_world()->add_translation(t);
  cam->mutable_video()->set_path("cam0.mkv");
  cam->mutable_video()->set_encoding(v1::SRGB);
  cam->mutable_video()->set_bit_depth(8);
  auto* light = scene.add_lights();
  light->set_name("NE");
  for (double p : {1.0, 3.0, 1.0}) light->add_position(p);
  auto* config = scene.add_light_configurations();
  config->set_name("NE only");
  config->add_lights("NE");
  auto* seed = scene.add_material_seeds();
  seed->set_name("cloth");
  for (unsigned c : {144u, 71u, 72u}) seed->add_srgb8(c);
  return scene;
}

TEST(ProtoJsonTest, SceneRoundTripsThroughJson) {
  const v1::Scene scene = MakeScene();
  const std::string json = MessageToJson(scene);
  EXPECT_NE(json.find("\"camFromWorld\""), std::string::npos) << json;
  v1::Scene back;
  ASSERT_TRUE(JsonToMessage(json, "test", &back).ok());
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(scene, back));
  EXPECT_EQ(MessageToJson(back), json);
}

TEST(ProtoJsonTest, UnknownFieldIsAnErrorNamingTheOrigin) {
  v1::Scene scene;
  const absl::Status s = JsonToMessage(R"({"name": "x", "meshh": {"path": "a.obj"}})", "scene.json", &scene);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("scene.json"), std::string::npos);
  EXPECT_NE(s.message().find("meshh"), std::string::npos) << s.message();
}

// Issue #19: duplicate keys were accepted silently (the last one won).
TEST(ProtoJsonTest, DuplicateKeyIsAnErrorNamingItsPath) {
  v1::Scene scene;
  absl::Status s = JsonToMessage(R"({"cameras": [{"name": "a"}, {"name": "b", "intrinsics": {"fx": 1, "fx": 2}}]})",
                                 "scene.json", &scene);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("scene.json: duplicate key \"fx\" in cameras[1].intrinsics"), std::string::npos)
      << s.message();
  s = JsonToMessage(R"({"name": "x", "frames": {"count": 2}, "name": "y"})", "scene.json", &scene);
  EXPECT_NE(s.message().find("duplicate key \"name\" in the top level"), std::string::npos) << s.message();
  // Equal keys in different objects, and keys inside strings, are fine.
  EXPECT_TRUE(
      JsonToMessage(R"({"name": "a \"name\": {", "cameras": [{"name": "a"}, {"name": "b"}]})", "scene.json", &scene)
          .ok());
}

TEST(ProtoJsonTest, MalformedJsonIsAnError) {
  v1::Scene scene;
  EXPECT_FALSE(JsonToMessage(R"({"name": )", "scene.json", &scene).ok());
  EXPECT_FALSE(JsonToMessage(R"({"frames": {"count": -3}})", "scene.json", &scene).ok());
}

TEST(ProtoJsonTest, FileRoundTrip) {
  const auto path = std::filesystem::temp_directory_path() / "mvbrdf_proto_json_test" / "scene.json";
  const v1::Scene scene = MakeScene();
  ASSERT_TRUE(WriteJsonFile(path, scene).ok());
  auto back = ReadJsonFileAs<v1::Scene>(path);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(scene, *back));
  std::filesystem::remove_all(path.parent_path());
}

}  // namespace
}  // namespace mvbrdf
