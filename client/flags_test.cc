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

TEST(FlagParserTest, HelpShowsTypedPlaceholders) {
  std::string out, text;
  int atlas = 512;
  double x = 1.5;
  bool flag = false;
  FlagParser parser("t", "synopsis");
  parser.AddString("--out DIR", &out, "out");
  parser.AddString("--text", &text, "text");
  parser.AddInt("--atlas N", &atlas, "atlas");
  parser.AddDouble("--x", &x, "x");
  parser.AddBool("--flag", &flag, "flag");
  const std::string usage = parser.Usage();
  for (const char* line : {"\n  --out DIR\n", "\n  --text TEXT\n", "\n  --atlas N\n", "\n  --x X\n", "\n  --flag\n"}) {
    EXPECT_NE(usage.find(line), std::string::npos) << line << " in\n" << usage;
  }
  EXPECT_EQ(usage.find("VALUE"), std::string::npos) << usage;
  // The flag is its name without the placeholder.
  EXPECT_TRUE(parser.Parse({"--out", "d", "--atlas=64"}).ok());
  EXPECT_EQ(out, "d");
  EXPECT_EQ(atlas, 64);
  const absl::Status bad = parser.Parse({"--atlas", "x"});
  EXPECT_EQ(bad.message(), "--atlas: expected an integer, got \"x\"");
}

TEST(FlagParserTest, UnknownFlagSuggestsTheClosest) {
  std::string out;
  int atlas = 512;
  FlagParser parser("run", "synopsis");
  parser.AddString("--out DIR", &out, "out");
  parser.AddInt("--atlas N", &atlas, "atlas");
  EXPECT_EQ(parser.Parse({"--atlass", "3"}).message(),
            "--atlass: unknown option for 'mvbrdf run'; did you mean --atlas? (see 'mvbrdf run --help')");
  EXPECT_EQ(parser.Parse({"--zzzzzzzz"}).message(),
            "--zzzzzzzz: unknown option for 'mvbrdf run' (see 'mvbrdf run --help')");
}

}  // namespace
}  // namespace mvbrdf::client
