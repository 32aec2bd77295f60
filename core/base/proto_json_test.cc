#include "core/base/proto_json.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <google/protobuf/util/message_differencer.h>

#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/text_format.h>
#include <google/protobuf/wrappers.pb.h>

#include "mvbrdf/v1/run_report.pb.h"
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

// Counts are JSON numbers (issue #20 item 5): Protobuf's mapping would write
// "texelsSeen": "5891".
TEST(ProtoJsonTest, SixtyFourBitCountsAreNumbers) {
  v1::RunReport report;
  report.set_scene("123");  // a string of digits stays a string
  report.set_texels_seen(5891);
  report.set_peak_rss_bytes(uint64_t{1} << 40);
  report.add_stages()->set_peak_rss_bytes(77);
  for (const std::string& json : {MessageToJson(report), MessageToJsonWithDefaults(report),
                                  MessageToOneLineJson(report)}) {
    std::string compact = json;
    compact.erase(std::remove_if(compact.begin(), compact.end(), [](char c) { return c == ' ' || c == '\n'; }),
                  compact.end());
    EXPECT_NE(compact.find("\"texelsSeen\":5891"), std::string::npos) << json;
    EXPECT_EQ(json.find("\"5891\""), std::string::npos) << json;
    EXPECT_NE(compact.find("\"scene\":\"123\""), std::string::npos) << json;
    EXPECT_NE(json.find("1099511627776"), std::string::npos) << json;
    EXPECT_EQ(json.find("\"1099511627776\""), std::string::npos) << json;
    EXPECT_EQ(json.find("\"77\""), std::string::npos) << json;
    v1::RunReport back;
    ASSERT_TRUE(JsonToMessage(json, "test", &back).ok()) << json;
    EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(report, back)) << json;
  }
}

// Every kind of 64-bit field, repeated, in a map, wrapped, nested, and a
// string field with the json name of a 64-bit field of another message: a
// message built at run time so the test needs no proto of its own.
TEST(ProtoJsonTest, EverySixtyFourBitKindIsANumberAndOnlyThose) {
  google::protobuf::FileDescriptorProto file;
  ASSERT_TRUE(google::protobuf::TextFormat::ParseFromString(R"pb(
    name: "proto_json_test.proto" package: "t" syntax: "proto3"
    dependency: "google/protobuf/wrappers.proto"
    message_type {
      name: "Inner"
      field { name: "n" number: 1 type: TYPE_STRING label: LABEL_OPTIONAL json_name: "n" }
      field { name: "small" number: 2 type: TYPE_UINT32 label: LABEL_OPTIONAL json_name: "small" }
    }
    message_type {
      name: "Outer"
      field { name: "n" number: 1 type: TYPE_INT64 label: LABEL_OPTIONAL json_name: "n" }
      field { name: "u" number: 2 type: TYPE_UINT64 label: LABEL_OPTIONAL json_name: "u" }
      field { name: "s" number: 3 type: TYPE_SINT64 label: LABEL_OPTIONAL json_name: "s" }
      field { name: "f" number: 4 type: TYPE_FIXED64 label: LABEL_OPTIONAL json_name: "f" }
      field { name: "sf" number: 5 type: TYPE_SFIXED64 label: LABEL_OPTIONAL json_name: "sf" }
      field { name: "list" number: 6 type: TYPE_INT64 label: LABEL_REPEATED json_name: "list" }
      field { name: "counts" number: 7 type: TYPE_MESSAGE label: LABEL_REPEATED type_name: ".t.Outer.CountsEntry" json_name: "counts" }
      field { name: "inner" number: 8 type: TYPE_MESSAGE label: LABEL_OPTIONAL type_name: ".t.Inner" json_name: "inner" }
      field { name: "inners" number: 9 type: TYPE_MESSAGE label: LABEL_REPEATED type_name: ".t.Inner" json_name: "inners" }
      field { name: "wrapped" number: 10 type: TYPE_MESSAGE label: LABEL_OPTIONAL type_name: ".google.protobuf.Int64Value" json_name: "wrapped" }
      field { name: "text" number: 11 type: TYPE_STRING label: LABEL_OPTIONAL json_name: "text" }
      nested_type {
        name: "CountsEntry" options { map_entry: true }
        field { name: "key" number: 1 type: TYPE_INT64 label: LABEL_OPTIONAL json_name: "key" }
        field { name: "value" number: 2 type: TYPE_UINT64 label: LABEL_OPTIONAL json_name: "value" }
      }
    }
  )pb", &file));
  google::protobuf::DescriptorPool pool(google::protobuf::DescriptorPool::generated_pool());
  const google::protobuf::FileDescriptor* fd = pool.BuildFile(file);
  ASSERT_NE(fd, nullptr);
  google::protobuf::DynamicMessageFactory factory(&pool);
  std::unique_ptr<google::protobuf::Message> m(factory.GetPrototype(fd->FindMessageTypeByName("Outer"))->New());
  ASSERT_TRUE(google::protobuf::TextFormat::ParseFromString(R"pb(
    n: -9007199254740993 u: 18446744073709551615 s: -5 f: 12 sf: -13 list: [1, -2, 3]
    counts { key: 4 value: 40 } counts { key: -5 value: 50 }
    inner { n: "123" small: 7 } inners { n: "456" } inners { n: "-1" }
    wrapped { value: 99 } text: "789"
  )pb", m.get()));
  const std::string json = MessageToOneLineJson(*m);
  EXPECT_EQ(json,
            R"({"n":-9007199254740993,"u":18446744073709551615,"s":-5,"f":12,"sf":-13,"list":[1,-2,3],)"
            R"("counts":{"4":40,"-5":50},"inner":{"n":"123","small":7},"inners":[{"n":"456"},{"n":"-1"}],)"
            R"("wrapped":99,"text":"789"})");
  // Beyond 2^53 the text is exact and Protobuf's parser reads it back exactly.
  std::unique_ptr<google::protobuf::Message> back(m->New());
  ASSERT_TRUE(JsonToMessage(MessageToJson(*m), "test", back.get()).ok()) << MessageToJson(*m);
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(*m, *back)) << MessageToJson(*m);
}

}  // namespace
}  // namespace mvbrdf
