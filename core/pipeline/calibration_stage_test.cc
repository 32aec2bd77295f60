// Issue #14 item 1, the integration: the cameras a camera refinement returns
// reach every stage of the run (pass 1, the sweep's Samples, pass 2, Table
// 7.1) and result.json; measured against the generator's truth, whatever
// calibrate::RefineCameras computes (here the refinement is given, as the
// service's gather task hands it on: the true cameras).
#include "core/pipeline/calibration_stage.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>

#include "core/base/proto_json.h"
#include "core/evaluate/reconstruction_evaluator.h"
#include "core/synth/ground_truth.h"
#include "core/synth/synthesizer.h"

namespace mvbrdf::pipeline {
namespace {

class CalibrationStageTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
    ASSERT_TRUE(context.ok()) << context.status();
    context_ = context->release();
    dir_ = std::filesystem::temp_directory_path() / ("mvbrdf_calibration_stage_test_" + std::to_string(getpid()));
    std::filesystem::remove_all(dir_);
    synth::SynthOptions so;
    so.num_frames = 4;
    so.width = 160;
    so.height = 120;
    so.actor_segments = 12;
    so.camera_rotation_error_deg = 0.5;
    so.camera_translation_error = 0.008;
    so.seed = 5;
    so.out_dir = dir_ / "bundle";
    auto synthesized = synth::Synthesize(so, *context_);
    ASSERT_TRUE(synthesized.ok()) << synthesized.status();
  }
  static void TearDownTestSuite() {
    delete context_;
    context_ = nullptr;
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }

  static ReconstructOptions Options(const std::string& out) {
    ReconstructOptions o;
    o.request.compare_solvers = false;
    o.request.correction = false;
    o.request.configuration = "NE,NW,SE,SW";
    o.atlas.size = 128;
    o.out_dir = dir_ / out;
    return o;
  }

  // The truth's cameras as a refinement that is to be used.
  static v1::CalibrationReport TrueCameras() {
    auto truth = synth::GroundTruth::Load(dir_ / "bundle" / "ground_truth" / "truth.json");
    EXPECT_TRUE(truth.ok()) << truth.status();
    v1::CalibrationReport report;
    report.set_cameras_mode("on");
    report.set_cameras_refined(true);
    report.set_cameras_decision("the true cameras, for the test");
    report.set_cameras_seconds(1.5);
    for (const v1::Camera& c : truth->message().cameras()) {
      v1::CameraRefinementRow* row = report.add_cameras();
      row->set_name(c.name());
      *row->mutable_camera() = c;
    }
    return report;
  }

  static gl::EglContext* context_;
  static std::filesystem::path dir_;
};

gl::EglContext* CalibrationStageTest::context_ = nullptr;
std::filesystem::path CalibrationStageTest::dir_;

double MeanMse(const v1::RunReport& report) {
  double sum = 0.0;
  for (const v1::CameraErrorRow& c : report.cameras()) sum += c.mse_brdf();
  return sum / std::max(1, report.cameras_size());
}

TEST_F(CalibrationStageTest, RefinedCamerasReachEveryStageAndResultJson) {
  auto sequence = scene::LoadSequence(dir_ / "bundle" / "scene.json");
  ASSERT_TRUE(sequence.ok()) << sequence.status();

  // The scene's cameras (refinement off): the calibration error stays.
  ReconstructOptions off = Options("off");
  off.refine_cameras = off.request.refine_cameras = v1::REFINEMENT_OFF;
  auto scene_run = RunReconstruction(*sequence, *context_, off);
  ASSERT_TRUE(scene_run.ok()) << scene_run.status();
  EXPECT_EQ(scene_run->calibration().cameras_mode(), "off");
  EXPECT_FALSE(scene_run->calibration().cameras_refined());
  EXPECT_EQ(scene_run->calibration().cameras_decision(), "--refine-cameras off");
  for (const v1::StageRow& s : scene_run->stages()) EXPECT_NE(s.name(), "refine_cameras");

  // The true cameras as the refinement (as the gather task hands it on).
  ReconstructOptions on = Options("on");
  on.refine_cameras = on.request.refine_cameras = v1::REFINEMENT_ON;
  on.calibration = TrueCameras();
  auto refined_run = RunReconstruction(*sequence, *context_, on);
  ASSERT_TRUE(refined_run.ok()) << refined_run.status();
  EXPECT_TRUE(refined_run->calibration().cameras_refined());
  ASSERT_EQ(refined_run->calibration().cameras_size(), 8);
  bool staged = false;
  for (const v1::StageRow& s : refined_run->stages()) {
    if (s.name() != "refine_cameras") continue;
    staged = true;
    EXPECT_DOUBLE_EQ(s.seconds(), 1.5);
  }
  EXPECT_TRUE(staged);
  // result.json holds the same.
  auto written = ReadJsonFileAs<v1::RunReport>(dir_ / "on" / "result.json");
  ASSERT_TRUE(written.ok()) << written.status();
  EXPECT_TRUE(written->calibration().cameras_refined());
  // The run's fingerprint is still the scene's (evaluate compares it with the truth's).
  EXPECT_EQ(written->input().SerializeAsString(), scene_run->input().SerializeAsString());

  // Against the truth: the cameras as used are the true ones...
  auto e_off = evaluate::EvaluateReconstruction(dir_ / "off", dir_ / "bundle");
  auto e_on = evaluate::EvaluateReconstruction(dir_ / "on", dir_ / "bundle");
  ASSERT_TRUE(e_off.ok()) << e_off.status();
  ASSERT_TRUE(e_on.ok()) << e_on.status();
  ASSERT_EQ(e_on->cameras_size(), 8);
  ASSERT_EQ(e_off->cameras_size(), 8);
  for (int c = 0; c < 8; ++c) {
    const v1::CameraTruthRow& a = e_off->cameras(c);
    const v1::CameraTruthRow& b = e_on->cameras(c);
    EXPECT_NEAR(a.rotation_error_deg_before(), 0.5, 1e-6) << a.name();
    EXPECT_NEAR(a.rotation_error_deg_after(), 0.5, 1e-6) << a.name();
    EXPECT_NEAR(a.centre_error_before(), 0.008, 1e-6) << a.name();
    EXPECT_GT(a.reprojection_error_px_after(), 0.5) << a.name();
    EXPECT_NEAR(b.rotation_error_deg_before(), 0.5, 1e-6) << b.name();
    EXPECT_LT(b.rotation_error_deg_after(), 1e-4) << b.name();
    EXPECT_LT(b.centre_error_after(), 1e-6) << b.name();
    EXPECT_LT(b.reprojection_error_px_after(), 1e-3) << b.name();
  }
  // ...and every stage used them: the resampled texels line up across
  // cameras, so the per-camera errors (Table 7.1, pass 2) and kd are better.
  std::printf("Table 7.1 mean BRDF MSE %.6g (scene's cameras) -> %.6g (true); kd RMSE %.4f -> %.4f\n",
              MeanMse(*scene_run), MeanMse(*refined_run), e_off->kd_rmse(), e_on->kd_rmse());
  EXPECT_LT(MeanMse(*refined_run), 0.9 * MeanMse(*scene_run)) << MeanMse(*refined_run) << " vs " << MeanMse(*scene_run);
  EXPECT_LT(e_on->kd_rmse(), e_off->kd_rmse()) << e_on->kd_rmse() << " vs " << e_off->kd_rmse();
}

TEST_F(CalibrationStageTest, ACalibrationNamingAnotherCameraOrSizeIsRefused) {
  auto sequence = scene::LoadSequence(dir_ / "bundle" / "scene.json");
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  v1::CalibrationReport report = TrueCameras();
  report.mutable_cameras(0)->set_name("nobody");
  auto bad = CalibratedSequence(*sequence, report);
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("\"nobody\""), std::string::npos) << bad.status();
  report = TrueCameras();
  report.mutable_cameras(1)->mutable_camera()->set_width(99);
  bad = CalibratedSequence(*sequence, report);
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("cam1"), std::string::npos) << bad.status();
  // Not refined: the scene's cameras, no copy.
  report.set_cameras_refined(false);
  auto same = CalibratedSequence(*sequence, report);
  ASSERT_TRUE(same.ok());
  EXPECT_FALSE(same->has_value());
}

}  // namespace
}  // namespace mvbrdf::pipeline
