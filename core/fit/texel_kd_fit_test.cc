#include "core/fit/texel_kd_fit.h"

#include <cmath>
#include <random>
#include <vector>

#include "core/base/draw_order.h"
#include "core/fit/fit_test_util.h"
#include "core/fit/phong_fit.h"
#include "gtest/gtest.h"

namespace mvbrdf::fit {
namespace {

using testing::GeneratorOptions;
using testing::MakePhong;
using testing::MakeSamples;

// A textured cluster: kd per texel +-40 % around the base, a broad lobe (the
// synthetic actor's cloth: ks 0.04, ke 4), noise-free.
struct Textured {
  PhongRgb truth = MakePhong({0.3, 0.2, 0.1}, {0.04, 0.04, 0.04}, {4.0, 4.0, 4.0});
  std::vector<glm::vec3> kd;
  samples::SampleSet set;
  samples::LightMask mask = samples::LightMask::FromBits(0xF);
};

Textured MakeTextured(uint32_t texels, size_t samples, double highlight_fraction = 0.5) {
  Textured t;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.6f, 1.4f);
  for (uint32_t e = 0; e < texels; ++e) {
    t.kd.push_back(glm::vec3(0.3f, 0.2f, 0.1f) * base::DrawVec3<glm::vec3>([&] { return u(rng); }));
  }
  GeneratorOptions g;
  g.num_samples = samples;
  g.num_elements = texels;
  g.highlight_fraction = highlight_fraction;
  t.set = MakeSamples(t.truth, g, t.kd);
  return t;
}

TEST(TexelKdFitTest, RecoversTheLobeUnderATexture) {
  const Textured t = MakeTextured(200, 8000);
  // Started away from the truth.
  const PhongRgb start = MakePhong({0.25, 0.25, 0.25}, {0.1, 0.1, 0.1}, {20.0, 20.0, 20.0});
  const auto r = FitLobeWithTexelKd(t.set, t.mask, start, {});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->texels, 200u);
  EXPECT_EQ(r->samples_used, 8000u);
  for (int c = 0; c < 3; ++c) {
    EXPECT_TRUE(r->channels[c].refined);
    EXPECT_NEAR(r->params[c].ks, 0.04, 0.04 * 1e-3) << c;
    EXPECT_NEAR(r->params[c].ke, 4.0, 4.0 * 1e-3) << c;
    EXPECT_LT(r->channels[c].cost, 1e-9 * r->channels[c].initial_cost) << c;
    // The cluster's kd: the illumination-weighted texel mean, within the texture's range.
    EXPECT_GT(r->params[c].kd, 0.6 * t.truth[c].kd);
    EXPECT_LT(r->params[c].kd, 1.4 * t.truth[c].kd);
  }
}

// The same data through the one-kd fit is off by far more: the texture is what
// the per-texel kd removes (the reason for this fit).
TEST(TexelKdFitTest, OneKdPerClusterIsWorseOnTheSameData) {
  const Textured t = MakeTextured(200, 8000);
  const auto one = FitPhong(t.set, {}, t.mask, {});
  ASSERT_TRUE(one.ok());
  const auto per_texel = FitLobeWithTexelKd(t.set, t.mask, one->params, {});
  ASSERT_TRUE(per_texel.ok());
  for (int c = 0; c < 3; ++c) {
    const double one_error = std::fabs(one->params[c].ks - 0.04) / 0.04 + std::fabs(one->params[c].ke - 4.0) / 4.0;
    const double texel_error =
        std::fabs(per_texel->params[c].ks - 0.04) / 0.04 + std::fabs(per_texel->params[c].ke - 4.0) / 4.0;
    EXPECT_GT(one_error, 100.0 * texel_error) << c << ": one kd " << one_error << ", per texel " << texel_error;
  }
}

// One Sample per texel: each texel's kd explains its Sample, nothing is left
// to inform the lobe, and the initial lobe is kept (not refined).
TEST(TexelKdFitTest, OneSamplePerTexelKeepsTheInitialLobe) {
  const Textured t = MakeTextured(500, 500);
  const PhongRgb start = MakePhong({0.25, 0.25, 0.25}, {0.1, 0.1, 0.1}, {20.0, 20.0, 20.0});
  const auto r = FitLobeWithTexelKd(t.set, t.mask, start, {});
  ASSERT_TRUE(r.ok());
  for (int c = 0; c < 3; ++c) {
    EXPECT_FALSE(r->channels[c].refined) << c;
    EXPECT_EQ(r->params[c].ks, 0.1);
    EXPECT_EQ(r->params[c].ke, 20.0);
  }
}

// Units: intensities x 1000 give kd and ks / 1000, ke unchanged.
TEST(TexelKdFitTest, IntensityScaleFree) {
  Textured t = MakeTextured(100, 4000);
  const auto a = FitLobeWithTexelKd(t.set, t.mask, t.truth, {});
  for (glm::vec3& i : t.set.light_intensity) i *= 1000.0f;
  PhongRgb scaled = t.truth;
  for (PhongChannel& p : scaled) p.kd /= 1000.0, p.ks /= 1000.0;
  const auto b = FitLobeWithTexelKd(t.set, t.mask, scaled, {});
  ASSERT_TRUE(a.ok() && b.ok());
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(b->params[c].ks * 1000.0, a->params[c].ks, 1e-6 * a->params[c].ks);
    EXPECT_NEAR(b->params[c].ke, a->params[c].ke, 1e-6 * a->params[c].ke);
  }
}

TEST(TexelKdFitTest, RefusesBadOptions) {
  const Textured t = MakeTextured(10, 100);
  TexelKdFitOptions o;
  o.ke_max = 0.5;
  EXPECT_FALSE(FitLobeWithTexelKd(t.set, t.mask, t.truth, o).ok());
  o = {};
  o.grid_points = 2;
  EXPECT_FALSE(FitLobeWithTexelKd(t.set, t.mask, t.truth, o).ok());
}

}  // namespace
}  // namespace mvbrdf::fit
