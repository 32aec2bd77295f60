#include "shaders/embedded_shaders.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

namespace mvbrdf::shaders {
namespace {

TEST(EmbeddedShadersTest, FindReturnsTheFileTextVerbatim) {
  const std::optional<std::string> embedded = Find("phong_model.glsl");
  ASSERT_TRUE(embedded.has_value());
  std::ifstream file(std::string(MVBRDF_SOURCE_DIR) + "/shaders/phong_model.glsl", std::ios::binary);
  ASSERT_TRUE(file.good());
  std::stringstream text;
  text << file.rdbuf();
  EXPECT_EQ(*embedded, text.str());
}

TEST(EmbeddedShadersTest, UnknownNameIsNullopt) { EXPECT_FALSE(Find("no_such_shader.frag").has_value()); }

TEST(EmbeddedShadersTest, NoFileCarriesItsOwnVersionLine) {
  const std::vector<std::string> names = Names();
  EXPECT_FALSE(names.empty());
  for (const std::string& name : names) {
    EXPECT_EQ(Find(name)->find("#version"), std::string::npos) << name;
  }
}

}  // namespace
}  // namespace mvbrdf::shaders
