#include "core/gl/shader_program.h"

#include <gtest/gtest.h>

#include "core/gl/egl_context.h"

namespace mvbrdf::gl {
namespace {

class ShaderProgramTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto context = EglContext::Create(EglPlatform::kSurfaceless);
    ASSERT_TRUE(context.ok()) << context.status();
    context_ = std::move(*context);
  }
  std::unique_ptr<EglContext> context_;
};

TEST(ShaderPreprocessTest, PrependsTheVersionAndExpandsIncludesOnce) {
  const absl::StatusOr<std::string> text = PreprocessShader(
      "main.frag", "#include \"phong_model.glsl\"\n  #  include \"phong_model.glsl\"\nvoid main() {}\n");
  ASSERT_TRUE(text.ok()) << text.status();
  EXPECT_EQ(text->rfind(kGlslVersion, 0), 0u);
  const size_t first = text->find("vec2 PhongCosines(");
  EXPECT_NE(first, std::string::npos);
  EXPECT_EQ(text->find("vec2 PhongCosines(", first + 1), std::string::npos);  // included once
  EXPECT_EQ(text->find("#include"), std::string::npos);
  EXPECT_NE(text->find("void main() {}"), std::string::npos);
}

TEST(ShaderPreprocessTest, MissingIncludeNamesTheIncludingFile) {
  const absl::StatusOr<std::string> text = PreprocessShader("main.frag", "\n#include \"nope.glsl\"\n");
  ASSERT_FALSE(text.ok());
  EXPECT_TRUE(absl::IsNotFound(text.status()));
  EXPECT_NE(text.status().message().find("main.frag"), absl::string_view::npos) << text.status();
  EXPECT_NE(text.status().message().find("line 2"), absl::string_view::npos) << text.status();
  EXPECT_NE(text.status().message().find("nope.glsl"), absl::string_view::npos) << text.status();
}

TEST_F(ShaderProgramTest, BuildsEveryEmbeddedProgram) {
  for (const auto& stages : std::vector<std::vector<ShaderStage>>{
           {{GL_VERTEX_SHADER, "phong.vert", {}}, {GL_FRAGMENT_SHADER, "phong.frag", {}}},
           {{GL_VERTEX_SHADER, "shadow.vert", {}}, {GL_FRAGMENT_SHADER, "shadow_point.frag", {}}},
           {{GL_VERTEX_SHADER, "shadow.vert", {}}, {GL_FRAGMENT_SHADER, "shadow_directional.frag", {}}}}) {
    absl::StatusOr<Program> program = BuildProgram(stages);
    ASSERT_TRUE(program.ok()) << program.status();
    EXPECT_TRUE(*program);
  }
}

TEST_F(ShaderProgramTest, CompileErrorNamesTheShaderAndCarriesTheLog) {
  const absl::StatusOr<Program> program = BuildProgram(
      {{GL_FRAGMENT_SHADER, "broken.frag",
        std::string("#include \"phong_model.glsl\"\nout vec4 color;\nvoid main() { color = undeclared_thing; }\n")}});
  ASSERT_FALSE(program.ok());
  const std::string message(program.status().message());
  EXPECT_NE(message.find("fragment shader \"broken.frag\""), std::string::npos) << message;
  EXPECT_NE(message.find("undeclared_thing"), std::string::npos) << message;  // from the driver's log
  // Line 3 of source string 0 (broken.frag), despite the expanded include.
  EXPECT_NE(message.find("0:3("), std::string::npos) << message;
  EXPECT_NE(message.find("0 = broken.frag"), std::string::npos) << message;
}

TEST_F(ShaderProgramTest, LinkErrorNamesTheShaders) {
  const absl::StatusOr<Program> program =
      BuildProgram({{GL_VERTEX_SHADER, "a.vert", std::string("void Missing();\nvoid main() { Missing(); }\n")},
                    {GL_FRAGMENT_SHADER, "b.frag", std::string("out vec4 c;\nvoid main() { c = vec4(1.0); }\n")}});
  ASSERT_FALSE(program.ok());
  const std::string message(program.status().message());
  EXPECT_NE(message.find("linking"), std::string::npos) << message;
  EXPECT_NE(message.find("a.vert"), std::string::npos) << message;
  EXPECT_NE(message.find("b.frag"), std::string::npos) << message;
}

TEST_F(ShaderProgramTest, UnknownEmbeddedShaderIsNotFound) {
  const absl::StatusOr<Program> program = BuildProgram({{GL_VERTEX_SHADER, "missing.vert", {}}});
  ASSERT_FALSE(program.ok());
  EXPECT_TRUE(absl::IsNotFound(program.status())) << program.status();
}

}  // namespace
}  // namespace mvbrdf::gl
