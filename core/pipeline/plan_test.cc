#include "core/pipeline/plan.h"

#include <gtest/gtest.h>

namespace mvbrdf::pipeline {
namespace {

// A sequence as the loader would produce it, without files: `configs`
// candidate configurations, `frames` frames, UVs or not, seeds or not.
scene::Sequence MakeSequence(int configs, int frames, bool uvs, bool seeds) {
  scene::Sequence s;
  s.num_frames = frames;
  s.cameras.resize(2);
  s.topology.triangles = {{0, 1, 2}};
  s.topology.render_to_file_vertex = {0, 1, 2};
  if (uvs) s.topology.uvs = {{0, 0}, {1, 0}, {0, 1}};
  for (int i = 0; i < configs; ++i) {
    auto* c = s.scene.add_light_configurations();
    c->set_name("config" + std::to_string(i));
    c->add_lights("L");
  }
  if (seeds) s.scene.add_material_seeds()->set_name("cloth");
  return s;
}

const v1::SkippedStage* FindSkipped(const Plan& plan, Stage stage) {
  for (const auto& s : plan.skipped) {
    if (s.name() == StageName(stage)) return &s;
  }
  return nullptr;
}

TEST(PlanTest, FullSceneRunsEverything) {
  RunRequest everything;
  everything.refine_lights = v1::REFINEMENT_ON;  // auto skips it (plan.cc says why)
  everything.normals = true;                      // off unless asked (issue #18)
  scene::Sequence s = MakeSequence(8, 30, false, true);
  s.lights.resize(1);
  auto plan = MakePlan(s, everything);
  ASSERT_TRUE(plan.ok()) << plan.status();
  for (Stage s : {Stage::kAtlas, Stage::kGatherSamples, Stage::kLightSweep, Stage::kClustering, Stage::kClusterFit,
                  Stage::kSolverComparison, Stage::kNormals, Stage::kTexelPass, Stage::kCorrection,
                  Stage::kCameraErrors, Stage::kWriteAtlases}) {
    EXPECT_TRUE(plan->Has(s)) << StageName(s);
  }
  EXPECT_TRUE(plan->skipped.empty());
  EXPECT_NE(plan->Describe().find("run   light_sweep: 8 candidate configurations"), std::string::npos);
}

// Issue #19 defect 8: the plan said "8 candidate configurations" when two
// were swept, and --direct swept all 8 whatever --candidates said.
TEST(PlanTest, CandidatesAreWhatTheSweepFitsAndThePlanCountsThem) {
  RunRequest request;
  request.candidates = {"config5", "config2"};
  auto plan = MakePlan(MakeSequence(8, 30, false, true), request);
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_TRUE(plan->Has(Stage::kLightSweep));
  EXPECT_EQ(plan->candidates, request.candidates);
  EXPECT_NE(plan->Describe().find("run   light_sweep: 2 candidate configurations (of the scene's 8): config5; config2"),
            std::string::npos)
      << plan->Describe();
  // Without candidates: the scene's, all of them.
  plan = MakePlan(MakeSequence(3, 30, false, true), {});
  ASSERT_TRUE(plan.ok());
  EXPECT_EQ(plan->candidates, (std::vector<std::string>{"config0", "config1", "config2"}));
  // One candidate is a known configuration.
  request.candidates = {"config4"};
  plan = MakePlan(MakeSequence(8, 30, false, true), request);
  ASSERT_TRUE(plan.ok());
  EXPECT_FALSE(plan->Has(Stage::kLightSweep));
  EXPECT_EQ(plan->fixed_configuration, "config4");
}

TEST(PlanTest, UnknownEmptyOrRepeatedCandidatesAreErrorsNamingTheFlag) {
  const scene::Sequence seq = MakeSequence(3, 30, false, true);
  RunRequest request;
  request.candidates = {"config1", "NE,NW"};
  auto plan = MakePlan(seq, request);
  EXPECT_EQ(plan.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(plan.status().message().find("--candidates: the scene has no light configuration \"NE,NW\""),
            std::string::npos)
      << plan.status();
  request.candidates = {"config1", ""};
  EXPECT_NE(MakePlan(seq, request).status().message().find("--candidates: configuration 2 is empty"),
            std::string::npos);
  request.candidates = {"config1", "config1"};
  EXPECT_NE(MakePlan(seq, request).status().message().find("--candidates: \"config1\" is listed twice"),
            std::string::npos);
  request.candidates = {"config1", "config2"};
  request.configuration = "config0";
  EXPECT_NE(MakePlan(seq, request).status().message().find("not both"), std::string::npos);
}

TEST(PlanTest, OneCandidateConfigurationSkipsTheSweep) {
  auto plan = MakePlan(MakeSequence(1, 30, false, true), {});
  ASSERT_TRUE(plan.ok());
  EXPECT_FALSE(plan->Has(Stage::kLightSweep));
  ASSERT_NE(FindSkipped(*plan, Stage::kLightSweep), nullptr);
  EXPECT_NE(FindSkipped(*plan, Stage::kLightSweep)->reason().find("one candidate"), std::string::npos);
  EXPECT_EQ(plan->fixed_configuration, "config0");
}

TEST(PlanTest, KnownConfigurationSkipsTheSweepAndUnknownIsAnError) {
  RunRequest request;
  request.configuration = "config3";
  auto plan = MakePlan(MakeSequence(8, 30, false, true), request);
  ASSERT_TRUE(plan.ok());
  EXPECT_FALSE(plan->Has(Stage::kLightSweep));
  EXPECT_EQ(plan->fixed_configuration, "config3");
  request.configuration = "nope";
  const auto bad = MakePlan(MakeSequence(8, 30, false, true), request);
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("nope"), std::string::npos);
}

TEST(PlanTest, SingleFrameSkipsCorrectionAtlases) {
  auto plan = MakePlan(MakeSequence(8, 1, false, true), {});
  ASSERT_TRUE(plan.ok());
  EXPECT_FALSE(plan->Has(Stage::kCorrection));
  ASSERT_NE(FindSkipped(*plan, Stage::kCorrection), nullptr);
  EXPECT_NE(FindSkipped(*plan, Stage::kCorrection)->reason().find("single frame"), std::string::npos);
}

TEST(PlanTest, MeshWithUvsSkipsAtlasBuilding) {
  auto plan = MakePlan(MakeSequence(8, 30, true, true), {});
  ASSERT_TRUE(plan.ok());
  EXPECT_FALSE(plan->Has(Stage::kAtlas));
  ASSERT_NE(FindSkipped(*plan, Stage::kAtlas), nullptr);
}

TEST(PlanTest, NoSeedsMeansAutomaticK) {
  auto plan = MakePlan(MakeSequence(8, 30, false, false), {});
  ASSERT_TRUE(plan.ok());
  ASSERT_TRUE(plan->Has(Stage::kClustering));
  EXPECT_NE(plan->Describe().find("k chosen automatically"), std::string::npos);
}

TEST(PlanTest, OutputsNotAskedForAreNotComputed) {
  RunRequest light_only;
  light_only.brdf_atlases = light_only.correction = light_only.camera_errors = false;
  auto plan = MakePlan(MakeSequence(8, 30, false, true), light_only);
  ASSERT_TRUE(plan.ok());
  EXPECT_TRUE(plan->Has(Stage::kLightSweep));
  for (Stage s : {Stage::kClustering, Stage::kClusterFit, Stage::kTexelPass, Stage::kCorrection,
                  Stage::kCameraErrors, Stage::kWriteAtlases}) {
    EXPECT_FALSE(plan->Has(s)) << StageName(s);
    EXPECT_NE(FindSkipped(*plan, s), nullptr) << StageName(s);
  }
  RunRequest no_extras;
  no_extras.correction = no_extras.camera_errors = no_extras.compare_solvers = false;
  plan = MakePlan(MakeSequence(8, 30, false, true), no_extras);
  ASSERT_TRUE(plan.ok());
  EXPECT_FALSE(plan->Has(Stage::kCorrection));
  EXPECT_FALSE(plan->Has(Stage::kCameraErrors));
  EXPECT_FALSE(plan->Has(Stage::kSolverComparison));
  EXPECT_TRUE(plan->Has(Stage::kWriteAtlases));
  RunRequest nothing;
  nothing.light_table = nothing.brdf_atlases = nothing.correction = nothing.camera_errors = false;
  EXPECT_EQ(MakePlan(MakeSequence(8, 30, false, true), nothing).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(PlanTest, PlanGoesIntoTheReport) {
  auto plan = MakePlan(MakeSequence(1, 1, true, false), {});
  ASSERT_TRUE(plan.ok());
  v1::Plan proto;
  plan->ToProto(&proto);
  EXPECT_EQ(proto.stages_size(), static_cast<int>(plan->steps.size()));
  // atlas, sweep, refine_lights (no sweep), normals (not asked), correction
  EXPECT_EQ(proto.skipped_size(), 5);
}

// Issue #18: the normals stage runs only when asked, before pass 2, and is
// skipped with its reason when too few light directions reach a texel.
TEST(PlanTest, NormalsRunWhenAskedAndTheObservationsCanConstrainThem) {
  scene::Sequence s = MakeSequence(1, 30, true, true);
  s.lights.resize(2);
  auto plan = MakePlan(s, {});
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_FALSE(plan->Has(Stage::kNormals));
  ASSERT_NE(FindSkipped(*plan, Stage::kNormals), nullptr);
  EXPECT_EQ(FindSkipped(*plan, Stage::kNormals)->reason(), "not requested (--outputs ...,normals)");
  RunRequest normals;
  normals.normals = true;
  plan = MakePlan(s, normals);
  ASSERT_TRUE(plan.ok()) << plan.status();
  ASSERT_TRUE(plan->Has(Stage::kNormals));
  size_t at_normals = 0, at_texel_pass = 0;
  for (size_t i = 0; i < plan->steps.size(); ++i) {
    if (plan->steps[i].stage == Stage::kNormals) at_normals = i;
    if (plan->steps[i].stage == Stage::kTexelPass) at_texel_pass = i;
  }
  EXPECT_LT(at_normals, at_texel_pass);
  // Only normals asked for: the reflectance stages they need run too.
  RunRequest only;
  only.light_table = only.brdf_atlases = only.correction = only.camera_errors = false;
  only.normals = true;
  plan = MakePlan(s, only);
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_TRUE(plan->Has(Stage::kNormals));
  EXPECT_TRUE(plan->Has(Stage::kClusterFit));
  // One light, one frame: one direction per texel.
  scene::Sequence one = MakeSequence(1, 1, true, true);
  one.lights.resize(1);
  plan = MakePlan(one, normals);
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_FALSE(plan->Has(Stage::kNormals));
  ASSERT_NE(FindSkipped(*plan, Stage::kNormals), nullptr);
  EXPECT_EQ(FindSkipped(*plan, Stage::kNormals)->reason(),
            "the observations cannot constrain normals: 1 light(s) x 1 frame(s), fewer than 3 light directions");
}

// Issue #14: camera refinement runs unless off (auto needs two cameras to
// compare); light refinement in auto only after a sweep, on also for a given
// configuration, never when every frame has its own lights.
TEST(PlanTest, RefinementStagesFollowTheModesAndTheScene) {
  const scene::Sequence s = MakeSequence(8, 3, false, true);
  auto plan = MakePlan(s, {});
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_TRUE(plan->Has(Stage::kRefineCameras));
  EXPECT_FALSE(plan->Has(Stage::kRefineLights));  // auto: only when asked (plan.cc says why)
  RunRequest request;
  request.refine_lights = v1::REFINEMENT_ON;
  EXPECT_TRUE(MakePlan(s, request)->Has(Stage::kRefineLights));
  request.refine_cameras = v1::REFINEMENT_OFF;
  request.refine_lights = v1::REFINEMENT_OFF;
  plan = MakePlan(s, request);
  ASSERT_TRUE(plan.ok());
  EXPECT_FALSE(plan->Has(Stage::kRefineCameras));
  EXPECT_FALSE(plan->Has(Stage::kRefineLights));
  request = {};
  request.configuration = "config3";
  plan = MakePlan(s, request);
  ASSERT_TRUE(plan.ok());
  EXPECT_FALSE(plan->Has(Stage::kRefineLights));  // auto
  request.refine_lights = v1::REFINEMENT_ON;
  plan = MakePlan(s, request);
  ASSERT_TRUE(plan.ok());
  EXPECT_TRUE(plan->Has(Stage::kRefineLights));
  scene::Sequence one = MakeSequence(1, 1, true, false);
  one.cameras.resize(1);
  request = {};
  EXPECT_FALSE(MakePlan(one, request)->Has(Stage::kRefineCameras));
  request.refine_cameras = v1::REFINEMENT_ON;
  EXPECT_TRUE(MakePlan(one, request)->Has(Stage::kRefineCameras));
}

// Issue #13: when every frame has its own lights there is no configuration to
// choose: the sweep is skipped, saying why, and every light is kept (each
// frame's Samples hold only its own). One frame without an entry: the sweep
// runs as before.
TEST(PlanTest, PerFrameLightingSkipsTheSweep) {
  scene::Sequence s = MakeSequence(8, 3, false, true);
  s.scene.mutable_frames()->set_count(3);
  for (uint32_t t = 0; t < 2; ++t) {
    auto* fl = s.scene.add_frame_lighting();
    fl->set_frame(t);
    fl->add_lights("L");
  }
  auto plan = MakePlan(s, {});
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_TRUE(plan->Has(Stage::kLightSweep));
  s.scene.add_frame_lighting()->set_frame(2);
  RunRequest request;
  request.configuration = "config3";
  plan = MakePlan(s, request);
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_FALSE(plan->Has(Stage::kLightSweep));
  EXPECT_EQ(plan->fixed_configuration, "");
  EXPECT_TRUE(plan->candidates.empty());
  const v1::SkippedStage* sweep = FindSkipped(*plan, Stage::kLightSweep);
  ASSERT_NE(sweep, nullptr);
  EXPECT_EQ(sweep->reason(),
            "lighting is given per frame (scene.frame_lighting names the lights of all 3 frames); --config config3 is "
            "not used");
  EXPECT_TRUE(plan->Has(Stage::kTexelPass));
  EXPECT_TRUE(plan->Has(Stage::kCorrection));
}

}  // namespace
}  // namespace mvbrdf::pipeline
