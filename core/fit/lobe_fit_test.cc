#include "core/fit/lobe_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "core/brdf/blinn_phong.h"
#include "core/brdf/geometry.h"
#include "core/brdf/ggx.h"
#include "core/brdf/phong.h"
#include "core/fit/fit_test_util.h"
#include "core/fit/lobe_texel_kd_fit.h"

namespace mvbrdf::fit {
namespace {

using testing::LobeTruth;
using Truth = LobeTruth;

samples::SampleSet Render(const Truth& truth, int num_samples, double noise, uint32_t seed,
                          double intensity_scale = 1.0, int texels = 0, double texture = 0.0) {
  return testing::RenderLobeSamples(truth, num_samples, noise, seed, intensity_scale, texels, texture);
}

// Parameters within `tolerance` relative; kd also within `kd_absolute`; GGX's
// f90_ratio within `ratio_tolerance` (default `tolerance`).
void ExpectRecovers(const Truth& truth, const LobeFitResult& fit, double tolerance, double kd_absolute = 0.0,
                    double ratio_tolerance = -1.0) {
  if (ratio_tolerance < 0.0) ratio_tolerance = tolerance;
  for (int c = 0; c < 3; ++c) {
    SCOPED_TRACE(std::string(brdf::ModelName(truth.model)) + " channel " + std::to_string(c));
    EXPECT_NEAR(fit.params[c].kd, truth.params[c].kd, std::max(kd_absolute, tolerance * truth.params[c].kd));
    EXPECT_NEAR(fit.params[c].p[0], truth.params[c].p[0], tolerance * truth.params[c].p[0]);
    EXPECT_NEAR(fit.params[c].p[1], truth.params[c].p[1], tolerance * truth.params[c].p[1]);
    if (brdf::NumParameters(truth.model) > 2) {
      EXPECT_NEAR(fit.params[c].p[2], truth.params[c].p[2], ratio_tolerance * truth.params[c].p[2]);
    }
  }
}

std::vector<Truth> Truths() {
  return {
      {BrdfModel::kPhong, {{{0.5, {0.3, 20.0}}, {0.3, {0.3, 25.0}}, {0.2, {0.2, 15.0}}}}},
      {BrdfModel::kBlinnPhong, {{{0.5, {0.4, 80.0}}, {0.3, {0.4, 100.0}}, {0.2, {0.3, 60.0}}}}},
      // A dielectric (F0 0.04, F90 / F0 25), a bright coloured metal (a
      // nearly flat Fresnel curve, F90 / F0 1.1 to 1.6: no diffuse) and a
      // lobe between them (F90 / F0 5, as MERL's plastics fit in
      // docs/models.md).
      {BrdfModel::kGgx, {{{0.25, {0.04, 0.3, 25.0}}, {0.2, {0.04, 0.3, 25.0}}, {0.15, {0.04, 0.3, 25.0}}}}},
      {BrdfModel::kGgx, {{{0.0, {0.9, 0.15, 1.1}}, {0.0, {0.7, 0.15, 1.3}}, {0.0, {0.4, 0.15, 1.6}}}}},
      {BrdfModel::kGgx, {{{0.3, {0.05, 0.2, 5.0}}, {0.2, {0.05, 0.2, 5.0}}, {0.1, {0.05, 0.2, 5.0}}}}},
  };
}

// Exactly, without GGX's prior on its ratio (which pulls a metal's 1.1 up
// where 3000 Samples barely tell it from kd; LobeFitTest.RatioPriorKeeps...).
TEST(LobeFitTest, EachModelRecoversItsOwnParametersExactly) {
  LobeFitOptions no_prior;
  no_prior.ratio_prior_sigma = 0.0;
  for (const Truth& truth : Truths()) {
    const samples::SampleSet set = Render(truth, 3000, 0.0, 1);
    auto fit = FitLobe(truth.model, set, {}, samples::LightMask::FirstN(6), no_prior);
    ASSERT_TRUE(fit.ok()) << fit.status();
    EXPECT_EQ(fit->samples_used, 3000u);
    EXPECT_EQ(fit->flags() & ~kAtBound, 0u) << brdf::ModelName(truth.model);
    ExpectRecovers(truth, *fit, 1e-4, 1e-6);
    EXPECT_LT(fit->mse, 1e-12);
  }
}

// The acceptance for GGX truth: roughness and F0 within 5 %, kd
// within 0.01 (its kd RMSE bound); here with 2 % multiplicative noise on
// every observation. The metal's kd and F90 / F0 trade (a little diffuse
// for a flatter curve) where only a few grazing observations tell them
// apart, and GGX's prior on the ratio pulls it towards 25: measured ratio
// 1.6, 1.6, 2.1 for 1.1, 1.3, 1.6, kd 0.011 to 0.015 for 0; within 60 % and
// 0.02 (the others: F0, roughness within 5 %, kd 0.01, the ratio 15 %).
TEST(LobeFitTest, NoisyObservationsWithinFivePercent) {
  for (const Truth& truth : Truths()) {
    const samples::SampleSet set = Render(truth, 3000, 0.02, 2);
    auto fit = FitLobe(truth.model, set, {}, samples::LightMask::FirstN(6), LobeFitOptions{});
    ASSERT_TRUE(fit.ok()) << fit.status();
    const bool metal = truth.params[0].kd == 0.0;
    ExpectRecovers(truth, *fit, 0.05, metal ? 0.02 : 0.01, metal ? 0.6 : 0.15);
  }
}

// Few Samples (300, 2 % noise) barely tell GGX's F0 from its ratio: the
// prior on the ratio (LobeFitOptions::ratio_prior_sigma) keeps a
// dielectric's F0 where the free ratio lets it drift.
TEST(LobeFitTest, RatioPriorKeepsADielectricsF0OnFewSamples) {
  const Truth truth = Truths()[2];
  double error[2] = {0.0, 0.0}, ratio_error[2] = {0.0, 0.0};
  for (uint32_t seed = 10; seed < 20; ++seed) {
    const samples::SampleSet set = Render(truth, 300, 0.02, seed);
    for (int prior = 0; prior < 2; ++prior) {
      LobeFitOptions options;
      options.ratio_prior_sigma = prior ? 1.0 : 0.0;
      auto fit = FitLobe(truth.model, set, {}, samples::LightMask::FirstN(6), options);
      ASSERT_TRUE(fit.ok()) << fit.status();
      for (int c = 0; c < 3; ++c) {
        error[prior] += std::abs(fit->params[c].p[0] / truth.params[c].p[0] - 1.0) / 30.0;
        ratio_error[prior] += std::abs(std::log(fit->params[c].p[2] / truth.params[c].p[2])) / 30.0;
      }
    }
  }
  std::printf("mean F0 error without the prior %.4f, with it %.4f; mean |ln ratio error| %.3f, %.3f\n", error[0],
              error[1], ratio_error[0], ratio_error[1]);
  EXPECT_LT(error[1], error[0]);
  EXPECT_LT(ratio_error[1], ratio_error[0]);
}

// No model depends on the lights' intensity units: every I_k x 8 gives kd
// and the lobe's scale (ks, F0) / 8 and the same shape.
TEST(LobeFitTest, ModelsDoNotDependOnIntensityUnits) {
  for (const Truth& truth : Truths()) {
    const samples::SampleSet set = Render(truth, 1500, 0.01, 3);
    samples::SampleSet scaled = set;
    for (glm::vec3& i : scaled.light_intensity) i *= 8.0f;
    auto a = FitLobe(truth.model, set, {}, samples::LightMask::FirstN(6), LobeFitOptions{});
    auto b = FitLobe(truth.model, scaled, {}, samples::LightMask::FirstN(6), LobeFitOptions{});
    ASSERT_TRUE(a.ok() && b.ok());
    for (int c = 0; c < 3; ++c) {
      SCOPED_TRACE(std::string(brdf::ModelName(truth.model)) + " channel " + std::to_string(c));
      EXPECT_NEAR(b->params[c].kd * 8.0, a->params[c].kd, 1e-6 * a->params[c].kd);
      EXPECT_NEAR(b->params[c].p[0] * 8.0, a->params[c].p[0], 1e-6 * a->params[c].p[0]);
      EXPECT_NEAR(b->params[c].p[1], a->params[c].p[1], 1e-6 * a->params[c].p[1]);
      EXPECT_NEAR(b->params[c].p[2], a->params[c].p[2], 1e-6 * std::max(1.0, a->params[c].p[2]));
    }
  }
}

// A sharp GGX lobe in data exposed 0.01x (a glossy material exposed for its
// highlights; MERL truth in scripts/bench-merl): with Schlick's F90 fixed at 1
// every such fit collapsed to F0 0, roughness 1 (issue #15); the scaled
// dielectric curve (ggx.h) recovers it.
TEST(LobeFitTest, SharpGgxLobeInDimDataIsRecovered) {
  const Truth truth{BrdfModel::kGgx,
                    {{{0.3, {0.04, 0.12, 25.0}}, {0.2, {0.04, 0.12, 25.0}}, {0.1, {0.04, 0.12, 25.0}}}}};
  samples::SampleSet set = Render(truth, 20000, 0.02, 5);
  for (glm::vec3& r : set.reflectance) r *= 0.01f;  // the images' exposure, not the lights'
  auto fit = FitLobe(truth.model, set, {}, samples::LightMask::FirstN(6), LobeFitOptions{});
  ASSERT_TRUE(fit.ok()) << fit.status();
  for (int c = 0; c < 3; ++c) {
    SCOPED_TRACE(c);
    EXPECT_NEAR(fit->params[c].kd, 0.01 * truth.params[c].kd, 0.05 * 0.01 * truth.params[c].kd);
    EXPECT_NEAR(fit->params[c].p[0], 0.01 * 0.04, 0.05 * 0.01 * 0.04);
    EXPECT_NEAR(fit->params[c].p[1], 0.12, 0.05 * 0.12);
  }
}

// On the thesis's model the generic fit and FitPhong (the fit of the thesis's
// tables) agree.
TEST(LobeFitTest, PhongAgreesWithFitPhong) {
  const Truth truth = Truths()[0];
  const samples::SampleSet set = Render(truth, 2000, 0.02, 4);
  auto lobe = FitLobe(BrdfModel::kPhong, set, {}, samples::LightMask::FirstN(6), LobeFitOptions{});
  auto phong = FitPhong(set, {}, samples::LightMask::FirstN(6), PhongFitOptions{});
  ASSERT_TRUE(lobe.ok() && phong.ok());
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(lobe->params[c].kd, phong->params[c].kd, 1e-4 * phong->params[c].kd);
    EXPECT_NEAR(lobe->params[c].p[0], phong->params[c].ks, 1e-4 * phong->params[c].ks);
    EXPECT_NEAR(lobe->params[c].p[1], phong->params[c].ke, 1e-4 * phong->params[c].ke);
  }
}

// A model is not always the truth: fitting Blinn-Phong and Phong to GGX
// data leaves a larger error than GGX's own fit (the model table
// in miniature), and every fit stays finite.
TEST(LobeFitTest, TheTrueModelFitsBest) {
  const Truth truth = Truths()[2];
  const samples::SampleSet set = Render(truth, 3000, 0.0, 5);
  double mse[3];
  int m = 0;
  for (BrdfModel model : {BrdfModel::kPhong, BrdfModel::kBlinnPhong, BrdfModel::kGgx}) {
    auto fit = FitLobe(model, set, {}, samples::LightMask::FirstN(6), LobeFitOptions{});
    ASSERT_TRUE(fit.ok()) << fit.status();
    for (const LobeChannel& c : fit->params) {
      EXPECT_TRUE(std::isfinite(c.kd) && std::isfinite(c.p[0]) && std::isfinite(c.p[1]));
    }
    mse[m++] = fit->mse;
    std::printf("%-12s fitted to GGX truth: mse %.3g\n", brdf::ModelName(model), fit->mse);
  }
  EXPECT_LT(mse[2], 1e-12);
  EXPECT_GT(mse[0], 1e3 * mse[2] + 1e-10);
  EXPECT_GT(mse[1], 1e3 * mse[2] + 1e-10);
}

TEST(LobeFitTest, HalfVectorModelsNeedTheGeometry) {
  samples::SampleSet set;
  set.light_names = {"A"};
  set.light_intensity = {glm::vec3(1.0f)};
  const float g = 0.5f, h = 0.9f;
  const uint16_t light = 0;
  set.AddTerms(0, 0, 0, glm::vec3(0.3f), 1, &light, &g, &h);
  auto blinn = FitLobe(BrdfModel::kBlinnPhong, set, {}, samples::LightMask::FirstN(1), LobeFitOptions{});
  ASSERT_FALSE(blinn.ok());
  EXPECT_EQ(blinn.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(blinn.status().message().find("half-vector"), absl::string_view::npos) << blinn.status();
  auto phong = FitLobe(BrdfModel::kPhong, set, {}, samples::LightMask::FirstN(1), LobeFitOptions{});
  ASSERT_TRUE(phong.ok()) << phong.status();
  EXPECT_NE(phong->flags() & kKsKeNotIdentifiable, 0u);  // one sample: no lobe to fit
}

// Issue #15: a cluster whose kd varies over its texels (+- 40 %) pulls the
// one-kd fit's lobe off; with kd free per texel every model's lobe comes
// back (texel_kd_fit.h's idea, for any model).
TEST(ModelLobeWithTexelKdTest, TexturedClusterRecoversTheLobe) {
  for (const Truth& truth : Truths()) {
    if (truth.params[0].kd == 0.0) continue;  // the metal: no texture to vary
    const samples::SampleSet set = Render(truth, 6000, 0.0, 6, 1.0, 300, 0.4);
    auto one_kd = FitLobe(truth.model, set, {}, samples::LightMask::FirstN(6), LobeFitOptions{});
    ASSERT_TRUE(one_kd.ok()) << one_kd.status();
    // Exactly: without GGX's prior on its ratio (which shifts a ratio of 5
    // by ~2 %, and F0 with it by ~0.2 %).
    LobeTexelKdOptions no_prior;
    no_prior.ratio_prior_sigma = 0.0;
    auto per_texel =
        FitModelLobeWithTexelKd(truth.model, set, samples::LightMask::FirstN(6), one_kd->params, no_prior);
    ASSERT_TRUE(per_texel.ok()) << per_texel.status();
    EXPECT_EQ(per_texel->texels, 300u);
    if (brdf::NumParameters(truth.model) > 2) {
      // With the prior (the default) a ratio below 25 (the lobe of ratio 5)
      // is searched to a value nearer 25 than without it, and still within
      // 5 % of the truth; a dielectric's stays.
      auto with_prior = FitModelLobeWithTexelKd(truth.model, set, samples::LightMask::FirstN(6), one_kd->params,
                                                LobeTexelKdOptions{});
      ASSERT_TRUE(with_prior.ok()) << with_prior.status();
      for (int c = 0; c < 3; ++c) {
        if (truth.params[c].p[2] < 20.0) {
          EXPECT_GT(with_prior->params[c].p[2], per_texel->params[c].p[2]) << c;
        }
        EXPECT_NEAR(with_prior->params[c].p[2], truth.params[c].p[2], 0.05 * truth.params[c].p[2]) << c;
      }
    }
    for (int c = 0; c < 3; ++c) {
      SCOPED_TRACE(std::string(brdf::ModelName(truth.model)) + " channel " + std::to_string(c));
      const double one_error = std::abs(one_kd->params[c].p[0] / truth.params[c].p[0] - 1.0);
      std::printf("%s c%d: p0 error one kd %.3f, per texel %.5f; shape %.4g vs %.4g\n",
                  brdf::ModelName(truth.model), c, one_error,
                  std::abs(per_texel->params[c].p[0] / truth.params[c].p[0] - 1.0), per_texel->params[c].p[1],
                  truth.params[c].p[1]);
      EXPECT_TRUE(per_texel->refined[c]);
      EXPECT_NEAR(per_texel->params[c].p[0], truth.params[c].p[0], 1e-3 * truth.params[c].p[0]);
      EXPECT_NEAR(per_texel->params[c].p[1], truth.params[c].p[1], 1e-3 * truth.params[c].p[1]);
      if (brdf::NumParameters(truth.model) > 2) {  // GGX's f90_ratio, searched too
        EXPECT_NEAR(per_texel->params[c].p[2], truth.params[c].p[2], 1e-2 * truth.params[c].p[2]);
      }
      EXPECT_LE(per_texel->held_out_error[c], per_texel->held_out_error_initial[c]);
    }
  }
}

}  // namespace
}  // namespace mvbrdf::fit
