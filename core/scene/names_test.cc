#include "core/scene/names.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "absl/strings/escaping.h"
#include "core/scene/scene_test_util.h"
#include "core/scene/sequence.h"

namespace mvbrdf::scene {
namespace {

TEST(NamesTest, AcceptsPlainAndNonAsciiNames) {
  for (const std::string& name : std::vector<std::string>{"cam0", "NE,NW,SE,SW", "café", "カメラ", "a b", "<b>", "\"q'",
                                                          "x.y", "-", "😀", std::string(kMaxNameBytes, 'a')}) {
    EXPECT_TRUE(ValidateName("f", name).ok()) << name << ": " << ValidateName("f", name);
  }
}

TEST(NamesTest, RejectsNamesThatCannotBeFileNames) {
  const std::string nul("a\0b", 3);
  for (const std::string& name :
       {std::string(), std::string("."), std::string(".."), std::string("../x"), std::string("/abs/x"),
        std::string("a/b"), std::string("a\\b"), nul, std::string("a\nb"), std::string("a\tb"),
        std::string("\x1b[31mred"), std::string("del\x7f"), std::string("c1\xc2\x85"), std::string("bad\xff"),
        std::string("overlong\xc0\xaf"), std::string("surrogate\xed\xa0\x80"), std::string("cut\xe2\x82"),
        std::string(kMaxNameBytes + 1, 'a')}) {
    const absl::Status s = ValidateName("scene.cameras[2].name", name);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << absl::CHexEscape(name);
    EXPECT_NE(s.message().find("scene.cameras[2].name: "), std::string::npos) << s;
    // The message shows control bytes escaped: it is one clean line.
    for (char c : s.message()) EXPECT_FALSE(static_cast<unsigned char>(c) < 0x20) << s;
  }
}

TEST(NamesTest, FileNameForStaysInsideItsDirectory) {
  auto ok = FileNameFor("/out/frames/0000", "cam0", "_grown.exr");
  ASSERT_TRUE(ok.ok()) << ok.status();
  EXPECT_EQ(*ok, std::filesystem::path("/out/frames/0000/cam0_grown.exr"));
  for (const std::string name : {"../x", "/abs/x", "..", "", "a/../../b"}) {
    EXPECT_EQ(FileNameFor("/out", name, ".exr").status().code(), absl::StatusCode::kInvalidArgument) << name;
  }
  // A suffix cannot smuggle a separator either.
  EXPECT_FALSE(FileNameFor("/out", "cam0", "/../../x").ok());
}

TEST(NamesTest, SceneValidationRejectsHostileNamesInEveryNameField) {
  const std::string hostile[] = {"../x", std::string("a\0b", 3), "\x1b[31m", "a\nb", std::string(200, 'n')};
  for (const std::string& name : hostile) {
    {
      v1::Scene scene = testing::FixtureScene();
      scene.mutable_cameras(1)->set_name(name);
      const absl::Status s = ValidateSceneMessage(scene);
      EXPECT_NE(s.message().find("scene.cameras[1].name: "), std::string::npos) << s;
    }
    {
      v1::Scene scene = testing::FixtureScene();
      ASSERT_GT(scene.lights_size(), 0);
      scene.mutable_lights(0)->set_name(name);
      const absl::Status s = ValidateSceneMessage(scene);
      EXPECT_NE(s.message().find("scene.lights[0].name: "), std::string::npos) << s;
    }
    {
      v1::Scene scene = testing::FixtureScene();
      scene.add_light_configurations()->set_name(name);
      const absl::Status s = ValidateSceneMessage(scene);
      EXPECT_NE(s.message().find(".name: "), std::string::npos) << s;
      EXPECT_NE(s.message().find("scene.light_configurations["), std::string::npos) << s;
    }
    {
      v1::Scene scene = testing::FixtureScene();
      v1::MaterialSeed* seed = scene.add_material_seeds();
      seed->set_name(name);
      for (int k = 0; k < 3; ++k) seed->add_srgb8(100);
      const absl::Status s = ValidateSceneMessage(scene);
      EXPECT_NE(s.message().find("scene.material_seeds["), std::string::npos) << s;
    }
  }
  v1::Scene cafe = testing::FixtureScene();
  cafe.mutable_cameras(0)->set_name("café");
  EXPECT_TRUE(ValidateSceneMessage(cafe).ok()) << ValidateSceneMessage(cafe);
}

TEST(NamesTest, ShownNameKeepsPrintableUtf8AndEscapesControls) {
  EXPECT_EQ(ShownName("café <b>"), "café <b>");
  EXPECT_EQ(ShownName(std::string("a\0b", 3)), "a\\x00b");
  EXPECT_EQ(ShownName("\x1b[31mred"), "\\x1b[31mred");
  EXPECT_EQ(ShownName("line\nnext\t"), "line\\x0anext\\x09");
  EXPECT_EQ(ShownName("\xc2\x9b"), "\\xc2\\x9b");  // U+009B, the C1 CSI
  EXPECT_EQ(ShownName("\xff"), "\\xff");          // not UTF-8
}

TEST(NamesTest, ShownTextKeepsNewlines) { EXPECT_EQ(ShownText("a\x1b\nb\n"), "a\\x1b\nb\n"); }

TEST(NamesTest, ReferenceErrorsShowTheNameEscaped) {
  v1::Scene scene = testing::FixtureScene();
  ASSERT_GT(scene.light_configurations_size(), 0);
  scene.mutable_light_configurations(0)->set_lights(0, "\x1b[2Jgone");
  const absl::Status s = ValidateSceneMessage(scene);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("unknown light \"\\x1b[2Jgone\""), std::string::npos) << s.message();
  EXPECT_EQ(s.message().find('\x1b'), std::string::npos);
}

}  // namespace
}  // namespace mvbrdf::scene

namespace mvbrdf::scene {
namespace {

TEST(NamesTest, NameListTruncatesLongLists) {
  EXPECT_EQ(NameList({}), "none");
  EXPECT_EQ(NameList({"cam0", "cam1"}), "\"cam0\", \"cam1\"");
  std::vector<std::string> many;
  for (int i = 0; i < 12; ++i) many.push_back("D" + std::to_string(i));
  EXPECT_EQ(NameList(many, 3), "\"D0\", \"D1\", \"D2\", \u2026 (12 in all)");
  EXPECT_EQ(NameList(many).find("D10"), std::string::npos);
}

TEST(NamesTest, ClosestNameSuggestsOnlyLikelyTypos) {
  EXPECT_EQ(ClosestName("--atlass", {"--atlas", "--out", "--grow"}), "--atlas");
  EXPECT_EQ(ClosestName("rnu", {"run", "render", "synth"}), "run");
  EXPECT_EQ(ClosestName("cam9", {"cam0", "cam1"}), "cam0");
  EXPECT_EQ(ClosestName("--zzzzzz", {"--atlas", "--out"}), "");
  EXPECT_EQ(ClosestName("x", {}), "");
}

}  // namespace
}  // namespace mvbrdf::scene
