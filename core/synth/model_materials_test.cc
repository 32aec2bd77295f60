#include "core/synth/model_materials.h"

#include <gtest/gtest.h>

#include <cmath>

namespace mvbrdf::synth {
namespace {

TEST(ModelMaterialsTest, ConversionsOfTheHeader) {
  StudioMaterial m;
  m.ks = glm::vec3(0.12f);
  m.ke = glm::vec3(16.0f, 4.0f, 40.0f);
  m.ior = 1.4f;
  const auto [ks, ke] = ModelParametersOf(brdf::Model::kPhong, m);
  EXPECT_EQ(ks, m.ks);
  EXPECT_EQ(ke, m.ke);
  const auto [ks_half, ke_half] = ModelParametersOf(brdf::Model::kBlinnPhong, m);
  EXPECT_EQ(ks_half, m.ks);
  EXPECT_EQ(ke_half, glm::vec3(64.0f, 16.0f, 160.0f));
  const auto [f0, roughness] = ModelParametersOf(brdf::Model::kGgx, m);
  EXPECT_NEAR(f0.x, (0.4 / 2.4) * (0.4 / 2.4), 1e-7);
  EXPECT_EQ(f0.x, f0.z);
  // alpha^2 = roughness^4 = 2 / (ke_half + 2).
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(std::pow(roughness[c], 4.0f), 2.0f / (ke_half[c] + 2.0f), 1e-6);
  EXPECT_GT(roughness.y, roughness.x);  // the wider lobe is rougher
}

}  // namespace
}  // namespace mvbrdf::synth
