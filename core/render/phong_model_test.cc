#include "core/render/phong_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace mvbrdf::render {
namespace {

constexpr float kTolerance = 1e-6f;

scene::Light PointLight(const glm::vec3& position, const glm::vec3& intensity = glm::vec3(1.0f)) {
  scene::Light light;
  light.position = position;
  light.intensity = intensity;
  return light;
}

void ExpectVecNear(const glm::vec3& actual, const glm::vec3& expected, float tolerance) {
  EXPECT_NEAR(actual.x, expected.x, tolerance);
  EXPECT_NEAR(actual.y, expected.y, tolerance);
  EXPECT_NEAR(actual.z, expected.z, tolerance);
}

const glm::vec3 kOrigin(0.0f);
const glm::vec3 kUp(0.0f, 0.0f, 1.0f);

TEST(PhongModelTest, LightStraightAboveFlatSurface) {
  // l = n = (0,0,1): g = 1, R = n; v = (1,0,1)/sqrt2: h = 1/sqrt2, h^2 = 1/2.
  const scene::Light light = PointLight({0, 0, 2}, {2, 1, 1});
  const glm::vec3 camera(1, 0, 1);
  const LightCosines c = ComputeLightCosines(light, kOrigin, kUp, camera, false);
  EXPECT_NEAR(c.g, 1.0f, kTolerance);
  EXPECT_NEAR(c.h, 1.0f / std::sqrt(2.0f), kTolerance);
  EXPECT_EQ(c.attenuation, 1.0f);

  PhongParams params;
  params.kd = {0.5f, 0.2f, 0.1f};
  params.ks = glm::vec3(0.3f);
  params.ke = glm::vec3(2.0f);
  // f = I * (kd * 1 + 0.3 * 0.5) = (2, 1, 1) * (0.65, 0.35, 0.25).
  ExpectVecNear(EvaluatePhong(params, kOrigin, kUp, camera, {light}, {}, false), {1.3f, 0.35f, 0.25f}, kTolerance);
}

TEST(PhongModelTest, MirrorConfigurationGivesFullHighlight) {
  // Light and camera symmetric about the normal: R(l) = v, h = 1 (the thesis's
  // l - 2(l.n)n would give -v and no highlight).
  const scene::Light light = PointLight({-1, 0, 1});
  const glm::vec3 camera(2, 0, 2);
  const LightCosines c = ComputeLightCosines(light, kOrigin, kUp, camera, false);
  EXPECT_NEAR(c.g, 1.0f / std::sqrt(2.0f), kTolerance);
  EXPECT_NEAR(c.h, 1.0f, kTolerance);

  PhongParams params;
  params.kd = glm::vec3(0.0f);
  params.ks = {0.1f, 0.2f, 0.4f};
  params.ke = {1.0f, 50.0f, 1000.0f};  // h = 1: any exponent gives 1
  ExpectVecNear(EvaluatePhong(params, kOrigin, kUp, camera, {light}, {}, false), params.ks, 1e-4f);
}

TEST(PhongModelTest, LightBelowTheSurfaceContributesNothing) {
  const scene::Light light = PointLight({0.3f, 0, -1});
  // The camera is in the mirror direction of the light below, which would
  // give R.v > 0 without the g = 0 rule.
  const glm::vec3 camera(-0.3f, 0, 1);
  const LightCosines c = ComputeLightCosines(light, kOrigin, kUp, camera, false);
  EXPECT_EQ(c.g, 0.0f);
  EXPECT_EQ(c.h, 0.0f);
  PhongParams params;
  params.kd = glm::vec3(1.0f);
  params.ks = glm::vec3(1.0f);
  params.ke = glm::vec3(1.0f);
  ExpectVecNear(EvaluatePhong(params, kOrigin, kUp, camera, {light}, {}, false), glm::vec3(0.0f), 0.0f);
}

TEST(PhongModelTest, HighlightCosineClampsAtZero) {
  // Camera on the light's side at grazing angle: R.v < 0 -> h = 0, only diffuse.
  const scene::Light light = PointLight({1, 0, 1});
  const glm::vec3 camera(10, 0, 0.01f);
  const LightCosines c = ComputeLightCosines(light, kOrigin, kUp, camera, false);
  EXPECT_GT(c.g, 0.0f);
  EXPECT_EQ(c.h, 0.0f);
  PhongParams params;
  params.kd = glm::vec3(0.5f);
  params.ks = glm::vec3(1.0f);
  params.ke = glm::vec3(3.0f);
  ExpectVecNear(EvaluatePhong(params, kOrigin, kUp, camera, {light}, {}, false), glm::vec3(0.5f * c.g), kTolerance);
}

TEST(PhongModelTest, InverseSquareFalloffOnPointLightsOnly) {
  const glm::vec3 camera(0, 1, 1);
  PhongParams params;
  params.kd = glm::vec3(0.8f);
  const scene::Light point = PointLight({0, 0, 2});
  EXPECT_NEAR(ComputeLightCosines(point, kOrigin, kUp, camera, true).attenuation, 0.25f, kTolerance);
  ExpectVecNear(EvaluatePhong(params, kOrigin, kUp, camera, {point}, {}, true), glm::vec3(0.2f), kTolerance);
  ExpectVecNear(EvaluatePhong(params, kOrigin, kUp, camera, {point}, {}, false), glm::vec3(0.8f), kTolerance);

  scene::Light directional;
  directional.directional = true;
  directional.direction = {0, 0, 5};  // normalised by the model
  const LightCosines c = ComputeLightCosines(directional, kOrigin, kUp, camera, true);
  EXPECT_EQ(c.attenuation, 1.0f);
  EXPECT_NEAR(c.g, 1.0f, kTolerance);
}

TEST(PhongModelTest, LightsAddUpAndVisibilityRemovesALight) {
  const scene::Light a = PointLight({0, 0, 1}, glm::vec3(1.0f));
  const scene::Light b = PointLight({1, 0, 0}, glm::vec3(3.0f));  // l = (1,0,0): g = 0 at n = up ...
  const scene::Light c = PointLight({0, 0, 4}, glm::vec3(0.5f));
  const glm::vec3 camera(0, 0, 3);
  PhongParams params;
  params.kd = glm::vec3(0.4f);
  ExpectVecNear(EvaluatePhong(params, kOrigin, kUp, camera, {a, b, c}, {}, false), glm::vec3(0.4f * 1.5f), kTolerance);
  ExpectVecNear(EvaluatePhong(params, kOrigin, kUp, camera, {a, b, c}, {true, true, false}, false), glm::vec3(0.4f),
                kTolerance);
}

TEST(PhongModelTest, ZeroExponentFollowsPowConventions) {
  // g > 0, h = 0: 0^0 = 1 (GLSL side: PhongLobe matches).
  const scene::Light light = PointLight({1, 0, 1});
  const glm::vec3 camera(10, 0, 0.01f);
  PhongParams params;
  params.ks = glm::vec3(1.0f);
  params.ke = {0.0f, 1.0f, 2.0f};
  const glm::vec3 f = EvaluatePhong(params, kOrigin, kUp, camera, {light}, {}, false);
  EXPECT_NEAR(f.x, 1.0f, kTolerance);
  EXPECT_EQ(f.y, 0.0f);
  EXPECT_EQ(f.z, 0.0f);
}

// Issue #13 item 4: the world x1000 (point, camera, light) gives the same
// radiance without fall-off, and with inverse-square fall-off once the
// intensities are x1000^2; a point light 1000 times further away stays finite
// and positive in float.
TEST(PhongModelTest, WorldScaleWithAndWithoutFalloff) {
  PhongParams params;
  params.kd = {0.5f, 0.2f, 0.1f};
  params.ks = glm::vec3(0.3f);
  params.ke = glm::vec3(20.0f);
  const glm::vec3 point(0.1f, -0.2f, 0.05f), normal = glm::normalize(glm::vec3(0.2f, 0.1f, 1.0f));
  const glm::vec3 camera(1.0f, 0.3f, 2.0f);
  const std::vector<scene::Light> lights = {PointLight({-0.4f, 0.2f, 1.5f}, {2, 1, 1}), PointLight({0.9f, 0.1f, 1.2f})};
  for (bool falloff : {false, true}) {
    SCOPED_TRACE(falloff);
    const glm::vec3 base = EvaluatePhong(params, point, normal, camera, lights, {}, falloff);
    std::vector<scene::Light> scaled = lights;
    for (scene::Light& l : scaled) {
      l.position *= 1000.0f;
      if (falloff) l.intensity *= 1e6f;
    }
    const glm::vec3 far = EvaluatePhong(params, 1000.0f * point, normal, 1000.0f * camera, scaled, {}, falloff);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(far[c] / base[c], 1.0f, 1e-5f);
  }
  // The light alone 1000 times further away: 1 / d^2 ~ 1e-6, still exact in float.
  const LightCosines near_light = ComputeLightCosines(PointLight({0, 0, 2}), kOrigin, kUp, kUp, true);
  const LightCosines far_light = ComputeLightCosines(PointLight({0, 0, 2000}), kOrigin, kUp, kUp, true);
  EXPECT_NEAR(far_light.attenuation * 1e6f / near_light.attenuation, 1.0f, 1e-5f);
  EXPECT_EQ(far_light.g, near_light.g);
}

}  // namespace
}  // namespace mvbrdf::render
