#include "core/fit/model_selection.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/fit/fit_test_util.h"

namespace mvbrdf::fit {
namespace {

using testing::LobeTruth;
using testing::RenderLobeSamples;

// Samples of 200 textured texels (kd +- 30 %) over 30 frames and 4 cameras,
// 2 % noise: every model's truth is picked, its held-out RMSE the lowest.
TEST(ModelSelectionTest, PicksTheModelTheDataCameFrom) {
  const std::vector<LobeTruth> truths = {
      {BrdfModel::kPhong, {{{0.5, {0.3, 20.0}}, {0.3, {0.3, 25.0}}, {0.2, {0.2, 15.0}}}}},
      {BrdfModel::kBlinnPhong, {{{0.5, {0.4, 80.0}}, {0.3, {0.4, 100.0}}, {0.2, {0.3, 60.0}}}}},
      {BrdfModel::kGgx, {{{0.25, {0.04, 0.3, 25.0}}, {0.2, {0.04, 0.3, 25.0}}, {0.15, {0.04, 0.3, 25.0}}}}},
      {BrdfModel::kGgx, {{{0.0, {0.9, 0.15, 1.1}}, {0.0, {0.7, 0.15, 1.3}}, {0.0, {0.4, 0.15, 1.6}}}}},
  };
  for (const LobeTruth& truth : truths) {
    SCOPED_TRACE(brdf::ModelName(truth.model));
    const samples::SampleSet set = RenderLobeSamples(truth, 6000, 0.02, 11, 1.0, 200, 0.3);
    auto selection = SelectModel(set, samples::LightMask::FirstN(6), {});
    ASSERT_TRUE(selection.ok()) << selection.status();
    std::printf("%s truth: held-out RMSE phong %.5f, blinn-phong %.5f, ggx %.5f -> %s (%s)\n",
                brdf::ModelName(truth.model), selection->held_out_rmse[0], selection->held_out_rmse[1],
                selection->held_out_rmse[2], brdf::ModelName(selection->model), selection->reason.c_str());
    EXPECT_EQ(selection->model, truth.model) << selection->reason;
    EXPECT_GT(selection->held_out, 1000u);
    EXPECT_GT(selection->training, 3000u);
    EXPECT_NE(selection->reason.find(brdf::ModelName(truth.model)), std::string::npos);
  }
}

// Another model must beat Phong by more than the margin: with a margin of
// 100 % Phong is always kept, and the reason says why.
TEST(ModelSelectionTest, MarginKeepsPhongAndSaysWhy) {
  const LobeTruth ggx = {BrdfModel::kGgx, {{{0.25, {0.04, 0.3, 25.0}}, {0.2, {0.04, 0.3, 25.0}}, {0.15, {0.04, 0.3, 25.0}}}}};
  const samples::SampleSet set = RenderLobeSamples(ggx, 3000, 0.02, 12, 1.0, 100, 0.3);
  ModelSelectionOptions options;
  options.margin = 1.0;
  auto selection = SelectModel(set, samples::LightMask::FirstN(6), options);
  ASSERT_TRUE(selection.ok()) << selection.status();
  EXPECT_EQ(selection->model, BrdfModel::kPhong);
  EXPECT_NE(selection->reason.find("phong kept"), std::string::npos) << selection->reason;
}

TEST(ModelSelectionTest, TooFewSamplesOrNoHalfVectorGeometry) {
  const LobeTruth ggx = {BrdfModel::kGgx, {{{0.25, {0.04, 0.3, 25.0}}, {0.2, {0.04, 0.3, 25.0}}, {0.15, {0.04, 0.3, 25.0}}}}};
  samples::SampleSet set = RenderLobeSamples(ggx, 30, 0.0, 13);
  auto few = SelectModel(set, samples::LightMask::FirstN(6), {});
  ASSERT_TRUE(few.ok()) << few.status();
  EXPECT_EQ(few->model, BrdfModel::kPhong);
  EXPECT_NE(few->reason.find("too few Samples"), std::string::npos) << few->reason;
  set.half_vector = false;
  EXPECT_EQ(SelectModel(set, samples::LightMask::FirstN(6), {}).status().code(),
            absl::StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace mvbrdf::fit
