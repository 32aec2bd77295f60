// The service's task chain (gather, sweep per configuration, choose,
// reflectance) run through RunTask gives exactly the outputs of one
// RunReconstruction with the same options.
#include "worker/task_runner.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <opencv2/core.hpp>
#include <vector>

#include "core/image/exr.h"
#include "core/pipeline/job_options.h"
#include "core/pipeline/reconstruct_stage.h"
#include "core/synth/synthesizer.h"

namespace mvbrdf::worker {
namespace {

namespace fs = std::filesystem;

class TaskRunnerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
    ASSERT_TRUE(context.ok()) << context.status();
    context_ = context->release();
    dir_ = fs::temp_directory_path() / ("mvbrdf_task_runner_test_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    synth::SynthOptions so;
    so.num_cameras = 4;
    so.num_frames = 3;
    so.out_dir = dir_ / "bundle";
    auto synthesized = synth::Synthesize(so, *context_);
    ASSERT_TRUE(synthesized.ok()) << synthesized.status();
    auto sequence = scene::LoadSequence(dir_ / "bundle" / "scene.json");
    ASSERT_TRUE(sequence.ok()) << sequence.status();
    sequence_ = new scene::Sequence(*std::move(sequence));
  }
  static void TearDownTestSuite() {
    delete sequence_;
    delete context_;
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  TaskEnvironment Environment(const std::string& scratch) {
    TaskEnvironment env;
    env.gl = context_;
    env.threads = 2;
    env.scratch_dir = dir_ / scratch;
    return env;
  }

  static v1::SubmitJobRequest Request() {
    v1::SubmitJobRequest request;
    request.mutable_options()->set_atlas_size(256);
    request.mutable_options()->set_compare_solvers(false);
    return request;
  }

  static gl::EglContext* context_;
  static scene::Sequence* sequence_;
  static fs::path dir_;
};

gl::EglContext* TaskRunnerTest::context_ = nullptr;
scene::Sequence* TaskRunnerTest::sequence_ = nullptr;
fs::path TaskRunnerTest::dir_;

cv::Mat ReadAtlas(const fs::path& file) {
  auto image = image::ReadExr(file);
  EXPECT_TRUE(image.ok()) << image.status();
  return image.ok() ? image->image : cv::Mat();
}

TEST_F(TaskRunnerTest, TaskChainEqualsOneProcessRun) {
  // The direct library run.
  auto options = pipeline::ReconstructOptionsFor(Request(), 2);
  ASSERT_TRUE(options.ok()) << options.status();
  options->out_dir = dir_ / "direct";
  auto direct = pipeline::RunReconstruction(*sequence_, *context_, *options);
  ASSERT_TRUE(direct.ok()) << direct.status();

  // The same job as tasks.
  v1::Task gather;
  gather.set_id("g");
  gather.set_kind("gather");
  *gather.mutable_request() = Request();
  TaskEnvironment gather_env = Environment("gather");
  gather_env.gather_texel_statistics = true;  // for the first reflectance below
  auto gathered = RunTask(gather, *sequence_, gather_env);
  ASSERT_TRUE(gathered.ok()) << gathered.status();
  ASSERT_NE(gathered->texel_statistics, nullptr);
  v1::GatherResult gather_result;
  ASSERT_TRUE(gather_result.ParseFromString(gathered->result));
  EXPECT_GT(gather_result.samples(), 1000u);
  EXPECT_EQ(gather_result.encoded_bytes(), gathered->samples.size());
  auto decoded = samples::DecodeSampleSet(gathered->samples);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  auto shared = std::make_shared<const samples::SampleSet>(*std::move(decoded));

  v1::Task choose;
  choose.set_id("c");
  choose.set_kind("choose");
  *choose.mutable_request() = Request();
  v1::TaskInput* gather_input = choose.add_inputs();
  gather_input->set_kind("gather");
  gather_input->set_result(gathered->result);
  for (const v1::LightConfiguration& c : sequence_->scene.light_configurations()) {
    v1::Task sweep;
    sweep.set_id("s-" + c.name());
    sweep.set_kind("sweep");
    sweep.set_key(c.name());
    *sweep.mutable_request() = Request();
    v1::TaskInput* in = sweep.add_inputs();
    in->set_kind("gather");
    in->set_result(gathered->result);
    TaskEnvironment env = Environment("sweep");
    env.samples = [&](const v1::GatherResult& g) -> absl::StatusOr<std::shared_ptr<const samples::SampleSet>> {
      EXPECT_EQ(g.samples_sha256(), gather_result.samples_sha256());
      return shared;
    };
    auto swept = RunTask(sweep, *sequence_, env);
    ASSERT_TRUE(swept.ok()) << swept.status();
    v1::TaskInput* row = choose.add_inputs();
    row->set_kind("sweep");
    row->set_key(c.name());
    row->set_result(swept->result);
  }
  // The choose task refines the chosen configuration's lights on the gather
  // task's Samples (the plan's refine_lights stage).
  TaskEnvironment choose_env = Environment("choose");
  choose_env.samples = [&](const v1::GatherResult& g) -> absl::StatusOr<std::shared_ptr<const samples::SampleSet>> {
    EXPECT_EQ(g.samples_sha256(), gather_result.samples_sha256());
    return shared;
  };
  auto chosen = RunTask(choose, *sequence_, choose_env);
  ASSERT_TRUE(chosen.ok()) << chosen.status();
  EXPECT_TRUE(chosen->artifacts.empty());  // the job goes on to reflectance

  v1::Task reflectance;
  reflectance.set_id("r");
  reflectance.set_kind("reflectance");
  *reflectance.mutable_request() = Request();
  v1::TaskInput* in = reflectance.add_inputs();
  in->set_kind("choose");
  in->set_result(chosen->result);
  // With the texel statistics of the gather pass (one worker), and without
  // them (the task gathers them itself): the same outputs either way.
  TaskEnvironment with_texels = Environment("reflectance");
  with_texels.texel_statistics = gathered->texel_statistics;
  auto reflected = RunTask(reflectance, *sequence_, with_texels);
  ASSERT_TRUE(reflected.ok()) << reflected.status();
  auto reflected_alone = RunTask(reflectance, *sequence_, Environment("reflectance_alone"));
  ASSERT_TRUE(reflected_alone.ok()) << reflected_alone.status();
  v1::RunReport report;
  ASSERT_TRUE(report.ParseFromString(reflected->result));

  // Table 6.1, the choice and Table 7.1 are the same numbers.
  ASSERT_EQ(report.light_configurations_size(), direct->light_configurations_size());
  for (int i = 0; i < report.light_configurations_size(); ++i) {
    EXPECT_EQ(report.light_configurations(i).name(), direct->light_configurations(i).name());
    EXPECT_EQ(report.light_configurations(i).e_a(), direct->light_configurations(i).e_a());
    EXPECT_EQ(report.light_configurations(i).e_d(), direct->light_configurations(i).e_d());
    EXPECT_EQ(report.light_configurations(i).e_held_out(), direct->light_configurations(i).e_held_out());
    EXPECT_EQ(report.light_configurations(i).lit_triangles(), direct->light_configurations(i).lit_triangles());
  }
  EXPECT_EQ(report.chosen_configuration(), direct->chosen_configuration());
  EXPECT_EQ(report.configuration_margin(), direct->configuration_margin());
  // Issue #14: the gather's camera refinement, handed on through choose, is
  // the one-process run's (its time aside).
  v1::CalibrationReport service_calibration = report.calibration(), direct_calibration = direct->calibration();
  EXPECT_FALSE(service_calibration.cameras_mode().empty());
  service_calibration.clear_cameras_seconds();
  direct_calibration.clear_cameras_seconds();
  // The light refinement (item 2) sums in another order on the two paths:
  // equal to rounding, then compared without it.
  ASSERT_EQ(service_calibration.lights_size(), direct_calibration.lights_size());
  for (int i = 0; i < service_calibration.lights_size(); ++i) {
    const v1::LightRefinementRow &a = service_calibration.lights(i), &b = direct_calibration.lights(i);
    EXPECT_EQ(a.name(), b.name());
    ASSERT_EQ(a.position_after_size(), b.position_after_size());
    for (int c = 0; c < a.position_after_size(); ++c) EXPECT_NEAR(a.position_after(c), b.position_after(c), 1e-9);
    ASSERT_EQ(a.intensity_after_size(), b.intensity_after_size());
    for (int c = 0; c < a.intensity_after_size(); ++c) EXPECT_NEAR(a.intensity_after(c), b.intensity_after(c), 1e-9);
  }
  EXPECT_EQ(service_calibration.lights_decision(), direct_calibration.lights_decision());
  for (v1::CalibrationReport* c : {&service_calibration, &direct_calibration}) {
    c->clear_lights();
    c->clear_lights_seconds();
  }
  EXPECT_EQ(service_calibration.DebugString(), direct_calibration.DebugString());
  EXPECT_EQ(gather_result.calibration().cameras_mode(), direct_calibration.cameras_mode());
  EXPECT_EQ(report.configuration_margin_e_d(), direct->configuration_margin_e_d());
  EXPECT_EQ(report.configuration_criterion(), direct->configuration_criterion());
  EXPECT_EQ(report.configuration_warning(), direct->configuration_warning());
  EXPECT_EQ(report.plan().DebugString(), direct->plan().DebugString());
  // The same stages: pass 1 reported once (by the gather, which gathered the
  // texel statistics too), the sweep, the fits, pass 2, the atlases.
  std::vector<std::string> stages, direct_stages;
  for (const auto& s : report.stages()) stages.push_back(s.name());
  for (const auto& s : direct->stages()) direct_stages.push_back(s.name());
  std::sort(stages.begin(), stages.end());
  std::sort(direct_stages.begin(), direct_stages.end());
  EXPECT_EQ(stages, direct_stages);
  ASSERT_EQ(report.cameras_size(), direct->cameras_size());
  for (int i = 0; i < report.cameras_size(); ++i) {
    EXPECT_EQ(report.cameras(i).mse_brdf(), direct->cameras(i).mse_brdf());
    EXPECT_EQ(report.cameras(i).mse_correction(), direct->cameras(i).mse_correction());
  }
  // The same files, and the same atlases texel for texel.
  std::vector<std::string> names;
  for (const auto& [name, path] : reflected->artifacts) names.push_back(name);
  std::vector<std::string> direct_names;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(dir_ / "direct")) {
    if (e.is_regular_file()) direct_names.push_back(fs::relative(e.path(), dir_ / "direct").generic_string());
  }
  std::sort(direct_names.begin(), direct_names.end());
  EXPECT_EQ(names, direct_names);
  for (const char* atlas : {"atlases/kd.exr", "atlases/ks.exr", "atlases/ke.exr", "atlases/cluster.exr"}) {
    const cv::Mat a = ReadAtlas(dir_ / "direct" / atlas);
    const cv::Mat b = ReadAtlas(dir_ / "reflectance" / atlas);
    const cv::Mat c = ReadAtlas(dir_ / "reflectance_alone" / atlas);
    ASSERT_FALSE(a.empty()) << atlas;
    ASSERT_EQ(a.size(), b.size()) << atlas;
    ASSERT_EQ(a.size(), c.size()) << atlas;
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0) << atlas;
    EXPECT_EQ(cv::norm(a, c, cv::NORM_INF), 0.0) << atlas;
  }
}

// Issue #14: the reflectance task resamples with the cameras of its gather's
// GatherResult.calibration (here cam0 moved 2 cm), not the scene's: its
// result.json says so and Table 7.1 shows it.
TEST_F(TaskRunnerTest, ReflectanceUsesTheGathersCameras) {
  v1::SubmitJobRequest request = Request();
  request.set_configuration("NE,NW,SE,SW");
  request.mutable_options()->set_refine_cameras(v1::REFINEMENT_ON);
  v1::CalibrationReport calibration;
  calibration.set_cameras_mode("on");
  calibration.set_cameras_refined(true);
  calibration.set_cameras_decision("cam0 moved for the test");
  calibration.set_cameras_seconds(0.25);
  for (const v1::Camera& c : sequence_->scene.cameras()) {
    v1::CameraRefinementRow* row = calibration.add_cameras();
    row->set_name(c.name());
    *row->mutable_camera() = c;
  }
  auto* translation = calibration.mutable_cameras(0)->mutable_camera()->mutable_cam_from_world()->mutable_translation();
  translation->Set(0, translation->Get(0) + 0.02);
  const auto run = [&](const v1::CalibrationReport& given, const std::string& scratch) {
    v1::GatherResult gathered;
    *gathered.mutable_calibration() = given;
    v1::Task reflectance;
    reflectance.set_kind("reflectance");
    reflectance.set_key("NE,NW,SE,SW");
    *reflectance.mutable_request() = request;
    v1::TaskInput* in = reflectance.add_inputs();
    in->set_kind("gather");
    gathered.SerializeToString(in->mutable_result());
    auto out = RunTask(reflectance, *sequence_, Environment(scratch));
    EXPECT_TRUE(out.ok()) << out.status();
    v1::RunReport report;
    if (out.ok()) {
      EXPECT_TRUE(report.ParseFromString(out->result));
    }
    return report;
  };
  v1::CalibrationReport scene_cameras = calibration;
  scene_cameras.set_cameras_refined(false);
  const v1::RunReport kept = run(scene_cameras, "kept");
  const v1::RunReport moved = run(calibration, "moved");
  EXPECT_FALSE(kept.calibration().cameras_refined());
  EXPECT_TRUE(moved.calibration().cameras_refined());
  EXPECT_EQ(moved.calibration().cameras_decision(), "cam0 moved for the test");
  bool staged = false;
  for (const v1::StageRow& s : moved.stages()) staged = staged || (s.name() == "refine_cameras" && s.seconds() == 0.25);
  EXPECT_TRUE(staged);
  ASSERT_EQ(moved.cameras_size(), kept.cameras_size());
  ASSERT_GT(moved.cameras_size(), 1);
  // cam0 no longer sees what the others see where they see it.
  EXPECT_GT(moved.cameras(0).mse_brdf(), 1.5 * kept.cameras(0).mse_brdf())
      << moved.cameras(0).mse_brdf() << " vs " << kept.cameras(0).mse_brdf();
}

TEST_F(TaskRunnerTest, LightTableOnlyEndsWithChoose) {
  v1::SubmitJobRequest request = Request();
  request.add_outputs(v1::OUTPUT_LIGHT_TABLE);
  v1::Task choose;
  choose.set_kind("choose");
  *choose.mutable_request() = request;
  v1::LightConfigurationRow a, b;
  a.set_name("A");
  a.set_e_d(2.0);
  a.set_e_a(1.0);
  b.set_name("B");
  b.set_e_d(1.0);
  b.set_e_a(3.0);
  for (const auto* row : {&a, &b}) {
    v1::TaskInput* in = choose.add_inputs();
    in->set_kind("sweep");
    row->SerializeToString(in->mutable_result());
  }
  auto chosen = RunTask(choose, *sequence_, Environment("choose-only"));
  ASSERT_TRUE(chosen.ok()) << chosen.status();
  v1::RunReport report;
  ASSERT_TRUE(report.ParseFromString(chosen->result));
  EXPECT_EQ(report.chosen_configuration(), "B");
  EXPECT_DOUBLE_EQ(report.configuration_margin(), 1.0);
  EXPECT_NE(report.configuration_warning().find("E_a prefers A"), std::string::npos);
  ASSERT_EQ(chosen->artifacts.size(), 1u);
  EXPECT_EQ(chosen->artifacts[0].first, "result.json");
  EXPECT_TRUE(fs::exists(chosen->artifacts[0].second));
}

// Issue #14: the choose task applies --sweep-criterion: the lowest held-out
// error by default (A), the lowest E_d with e-d (B); the margins of both.
TEST_F(TaskRunnerTest, ChooseAppliesTheSweepCriterion) {
  v1::LightConfigurationRow a, b;
  a.set_name("A");
  a.set_e_d(2.0);
  a.set_e_a(1.0);
  a.set_e_held_out(1.0);
  b.set_name("B");
  b.set_e_d(1.0);
  b.set_e_a(3.0);
  b.set_e_held_out(1.5);
  for (const v1::SweepCriterion criterion : {v1::SWEEP_CRITERION_HELD_OUT, v1::SWEEP_CRITERION_E_D}) {
    v1::SubmitJobRequest request = Request();
    request.add_outputs(v1::OUTPUT_LIGHT_TABLE);
    request.mutable_options()->set_sweep_criterion(criterion);
    v1::Task choose;
    choose.set_kind("choose");
    *choose.mutable_request() = request;
    for (const auto* row : {&a, &b}) {
      v1::TaskInput* in = choose.add_inputs();
      in->set_kind("sweep");
      row->SerializeToString(in->mutable_result());
    }
    auto chosen = RunTask(choose, *sequence_, Environment("choose-criterion"));
    ASSERT_TRUE(chosen.ok()) << chosen.status();
    v1::RunReport report;
    ASSERT_TRUE(report.ParseFromString(chosen->result));
    EXPECT_DOUBLE_EQ(report.configuration_margin_e_d(), 1.0);
    if (criterion == v1::SWEEP_CRITERION_HELD_OUT) {
      EXPECT_EQ(report.chosen_configuration(), "A");
      EXPECT_EQ(report.configuration_criterion(), "held-out");
      EXPECT_DOUBLE_EQ(report.configuration_margin(), 0.5);
      EXPECT_EQ(report.configuration_warning(), "");
    } else {
      EXPECT_EQ(report.chosen_configuration(), "B");
      EXPECT_EQ(report.configuration_criterion(), "e-d");
      EXPECT_DOUBLE_EQ(report.configuration_margin(), 1.0);
      EXPECT_NE(report.configuration_warning().find("E_a prefers A"), std::string::npos);
    }
  }
}

TEST_F(TaskRunnerTest, BadTasksAreRejectedNamingTheField) {
  v1::Task task;
  task.set_kind("paint");
  auto r = RunTask(task, *sequence_, Environment("bad"));
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("kind"), std::string::npos);

  task.set_kind("sweep");
  task.set_key("NE,NW,SE,SW");
  r = RunTask(task, *sequence_, Environment("bad"));
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("inputs"), std::string::npos);

  v1::TaskInput* in = task.add_inputs();
  in->set_kind("gather");
  task.set_key("no such configuration");
  r = RunTask(task, *sequence_, Environment("bad"));
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("key"), std::string::npos);
}

TEST_F(TaskRunnerTest, CancelledGatherStops) {
  v1::Task gather;
  gather.set_kind("gather");
  *gather.mutable_request() = Request();
  TaskEnvironment env = Environment("cancel");
  env.cancelled = [] { return true; };
  auto r = RunTask(gather, *sequence_, env);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kCancelled);
}

}  // namespace
}  // namespace mvbrdf::worker
