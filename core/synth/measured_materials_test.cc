#include "core/synth/measured_materials.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

namespace mvbrdf::synth {
namespace {

// A merl_nbrdf.json with constant networks: every weight 0 but b3 =
// log(1 + rho), so the material's rho is `rho` everywhere.
std::filesystem::path WriteConstantMaterials(const std::vector<std::pair<std::string, glm::dvec3>>& materials) {
  const auto layer = [](int in, int out, const std::vector<double>& bias) {
    std::ostringstream s;
    s << "{\"kernel\": [";
    for (int i = 0; i < in; ++i) {
      s << (i ? "," : "") << "[";
      for (int j = 0; j < out; ++j) s << (j ? "," : "") << "0";
      s << "]";
    }
    s << "], \"bias\": [";
    for (int j = 0; j < out; ++j) s << (j ? "," : "") << (bias.empty() ? 0.0 : bias[static_cast<size_t>(j)]);
    s << "]}";
    return s.str();
  };
  std::ostringstream json;
  json << "{\"materials\": {";
  for (size_t m = 0; m < materials.size(); ++m) {
    const glm::dvec3& rho = materials[m].second;
    json << (m ? "," : "") << "\"" << materials[m].first << "\": [" << layer(6, 21, {}) << "," << layer(21, 21, {})
         << "," << layer(21, 3, {std::log1p(rho.x), std::log1p(rho.y), std::log1p(rho.z)}) << "]";
  }
  json << "}}";
  const std::filesystem::path file = std::filesystem::path(testing::TempDir()) / "constant_nbrdf.json";
  std::ofstream(file) << json.str();
  return file;
}

const std::vector<std::string> kSlots = {"cloth", "skin", "hair"};

TEST(MeasuredMaterialsTest, SlotsByNameOrInOrderAndDashKeepsAnalytic) {
  const auto file = WriteConstantMaterials({{"red", {0.3, 0.1, 0.1}}, {"blue", {0.1, 0.1, 0.3}}});
  auto in_order = ResolveMeasuredMaterials("red,-,blue", kSlots, file);
  ASSERT_TRUE(in_order.ok()) << in_order.status();
  ASSERT_EQ(in_order->size(), 3u);
  ASSERT_TRUE((*in_order)[0].has_value());
  EXPECT_EQ((*in_order)[0]->name, "red");
  EXPECT_FALSE((*in_order)[1].has_value());
  EXPECT_EQ((*in_order)[2]->name, "blue");
  auto by_name = ResolveMeasuredMaterials("hair=red, skin = blue", kSlots, file);
  ASSERT_TRUE(by_name.ok()) << by_name.status();
  EXPECT_FALSE((*by_name)[0].has_value());
  EXPECT_EQ((*by_name)[1]->name, "blue");
  EXPECT_EQ((*by_name)[2]->name, "red");
  EXPECT_NEAR((*by_name)[2]->brdf.Evaluate({0, 0, 1}, {0.6, 0, 0.8}).x, 0.3, 1e-6);
  // No measured slot needs no file.
  auto none = ResolveMeasuredMaterials("-,-", kSlots, "");
  ASSERT_TRUE(none.ok()) << none.status();
}

TEST(MeasuredMaterialsTest, BadSpecsNameTheEntry) {
  const auto file = WriteConstantMaterials({{"red", {0.3, 0.1, 0.1}}});
  const auto message = [&](const std::string& spec, const std::filesystem::path& f) {
    auto r = ResolveMeasuredMaterials(spec, kSlots, f);
    EXPECT_FALSE(r.ok()) << spec;
    return r.ok() ? std::string() : std::string(r.status().message());
  };
  EXPECT_NE(message("shoes=red", file).find("no material slot \"shoes\""), std::string::npos);
  EXPECT_NE(message("red,red,red,red", file).find("3 material slots"), std::string::npos);
  EXPECT_NE(message("cloth=red,cloth=red", file).find("given twice"), std::string::npos);
  EXPECT_NE(message("red,,red", file).find("empty entry"), std::string::npos);
  EXPECT_NE(message("green", file).find("slot \"cloth\""), std::string::npos);
  EXPECT_NE(message("red", "").find("--merl-file"), std::string::npos);
}

TEST(MeasuredMaterialsTest, DiffuseColourOfAConstantBrdfIsItsRho) {
  const auto file = WriteConstantMaterials({{"grey", {0.2, 0.25, 0.3}}});
  auto m = brdf::LoadNeuralBrdf(file, "grey");
  ASSERT_TRUE(m.ok()) << m.status();
  const glm::dvec3 c = DiffuseColour(*m);
  EXPECT_NEAR(c.x, 0.2, 1e-6);
  EXPECT_NEAR(c.y, 0.25, 1e-6);
  EXPECT_NEAR(c.z, 0.3, 1e-6);
}

// A constant rho reflects pi rho of the light (the quadrature is exact for
// it), so the gain that matches a Lambertian kd is kd / rho, within bounds.
TEST(MeasuredMaterialsTest, GainMatchesTheAlbedoOfTheSlotsKd) {
  const auto file = WriteConstantMaterials({{"grey", {0.1, 0.1, 0.1}}, {"black", {0.0, 0.0, 0.0}}});
  auto grey = brdf::LoadNeuralBrdf(file, "grey");
  auto black = brdf::LoadNeuralBrdf(file, "black");
  ASSERT_TRUE(grey.ok() && black.ok());
  EXPECT_NEAR(DirectionalAlbedo(*grey), 3.14159265358979 * 0.1, 1e-6);
  EXPECT_NEAR(MeasuredGain(*grey, 0.4), 4.0, 1e-5);
  EXPECT_NEAR(MeasuredGain(*grey, 100.0), 16.0, 1e-9);
  EXPECT_NEAR(MeasuredGain(*grey, 0.001), 0.25, 1e-9);
  EXPECT_NEAR(MeasuredGain(*black, 0.4), 16.0, 1e-9);
  // Exposed for its highlights: its peak is rho cos(0) = 0.1 per unit
  // intensity, so under a light of 1.5 the gain is 0.9 / 0.15.
  EXPECT_NEAR(PeakReflectance(*grey), 0.1, 1e-6);  // the JSON holds float32 weights
  EXPECT_NEAR(MeasuredGain(*grey, 0.4, 1.5), 6.0, 1e-4);
}

}  // namespace
}  // namespace mvbrdf::synth
