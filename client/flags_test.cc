#include "client/flags.h"

#include <gtest/gtest.h>

namespace mvbrdf::client {
namespace {

struct Parsed {
  std::string scene, out = "default";
  int cameras = 8;
  uint32_t seed = 1;
  double noise = 1.0;
  bool lossy = false;
};

absl::Status ParseInto(const std::vector<std::string>& args, Parsed* p, FlagParser* parser) {
  parser->AddPositional("SCENE", &p->scene, false, "scene");
  parser->AddString("--out", &p->out, "out");
  parser->AddInt("--cameras", &p->cameras, "cameras");
  parser->AddUint("--seed", &p->seed, "seed");
  parser->AddDouble("--noise", &p->noise, "noise");
  parser->AddBool("--lossy", &p->lossy, "lossy");
  return parser->Parse(args);
}

TEST(FlagParserTest, ParsesAllForms) {
  Parsed p;
  FlagParser parser("synth", "test");
  ASSERT_TRUE(ParseInto({"s.json", "--out", "dir", "--cameras=3", "--seed", "7", "--noise=0.5", "--lossy"}, &p, &parser).ok());
  EXPECT_EQ(p.scene, "s.json");
  EXPECT_EQ(p.out, "dir");
  EXPECT_EQ(p.cameras, 3);
  EXPECT_EQ(p.seed, 7u);
  EXPECT_DOUBLE_EQ(p.noise, 0.5);
  EXPECT_TRUE(p.lossy);
}

TEST(FlagParserTest, KeepsDefaults) {
  Parsed p;
  FlagParser parser("synth", "test");
  ASSERT_TRUE(ParseInto({}, &p, &parser).ok());
  EXPECT_EQ(p.cameras, 8);
  EXPECT_EQ(p.out, "default");
  EXPECT_NE(parser.Usage().find("(default: 8)"), std::string::npos) << parser.Usage();
}

TEST(FlagParserTest, ErrorsNameTheFlag) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--cameras", "x"}, "--cameras: expected an integer"},
      {{"--cameras", "3.5"}, "--cameras: expected an integer"},
      {{"--seed", "-1"}, "--seed: expected a non-negative integer"},
      {{"--noise", "nan"}, "--noise: expected a finite number"},
      {{"--lossy=maybe"}, "--lossy: expected true or false"},
      {{"--out"}, "--out: expected a value"},
      {{"--colour", "red"}, "--colour: unknown option"},
      {{"a", "b"}, "unexpected argument \"b\""},
  };
  for (const auto& [args, message] : cases) {
    Parsed p;
    FlagParser parser("synth", "test");
    const absl::Status s = ParseInto(args, &p, &parser);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << message;
    EXPECT_NE(s.message().find(message), std::string::npos) << s.message();
  }
}

TEST(FlagParserTest, RequiredPositionalAndHelp) {
  std::string scene;
  FlagParser parser("validate", "test");
  parser.AddPositional("SCENE", &scene, true, "scene");
  EXPECT_NE(parser.Parse({}).message().find("SCENE: required"), std::string::npos);
  FlagParser help("validate", "test");
  help.AddPositional("SCENE", &scene, true, "scene");
  ASSERT_TRUE(help.Parse({"--help"}).ok());
  EXPECT_TRUE(help.help_requested());
}

}  // namespace
}  // namespace mvbrdf::client
