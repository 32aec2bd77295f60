// The whole reconstruction on a small generated sequence, measured against
// the generator's ground truth.
#include "core/pipeline/reconstruct_stage.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <limits>

#include "core/evaluate/reconstruction_evaluator.h"
#include "core/image/exr.h"
#include "core/synth/synthesizer.h"

namespace mvbrdf::pipeline {
namespace {

// Thresholds from measurement on this sequence (actor, 8 cameras x 12
// frames, 320x240, sensor noise 1 code value, 512^2 atlas; `mvbrdf synth
// --frames 12` then `mvbrdf run` and `mvbrdf evaluate`): kd RMSE 0.0170
// (median 0.0030; cloth 0.013, skin 0.029, hair 0.023), cluster accuracy
// 0.990, ks relative error 0.198 / 0.039 / 0.007 and ke 0.052 / 0.077 /
// 0.043 (cloth / skin / hair). Cloth's ks is the hard one: its red kd (0.28,
// varying by 25 % over the surface) swamps a 0.04 lobe in the red channel.
// With 4 frames the sweep cannot yet tell NE,NW,SE,SW from NE,NW,SE,SW,C
// (E_d differ by 1 % at 12 frames, 3 % at 30).
constexpr double kMaxKdRmse = 0.022;
constexpr double kMinClusterAccuracy = 0.97;
constexpr double kMaxKsRelError = 0.3;
constexpr double kMaxKeRelError = 0.15;

class ReconstructStageTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
    ASSERT_TRUE(context.ok()) << context.status();
    context_ = context->release();
    // One directory per process: ctest runs the tests of this suite in
    // parallel processes, each with its own bundle.
    dir_ = std::filesystem::temp_directory_path() / ("mvbrdf_reconstruct_stage_test_" + std::to_string(getpid()));
    std::filesystem::remove_all(dir_);
    synth::SynthOptions so;
    so.num_frames = 12;
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

  static gl::EglContext* context_;
  static std::filesystem::path dir_;
};

gl::EglContext* ReconstructStageTest::context_ = nullptr;
std::filesystem::path ReconstructStageTest::dir_;

TEST_F(ReconstructStageTest, RecoversTheGroundTruth) {
  auto sequence = scene::LoadSequence(dir_ / "bundle" / "scene.json");
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  ReconstructOptions options;
  options.request.compare_solvers = false;
  options.out_dir = dir_ / "run";
  auto report = RunReconstruction(*sequence, *context_, options);
  ASSERT_TRUE(report.ok()) << report.status();

  // Table 6.1: all eight candidates, the right one chosen.
  ASSERT_EQ(report->light_configurations_size(), 8);
  for (const auto& row : report->light_configurations()) {
    EXPECT_TRUE(std::isfinite(row.e_a()) && std::isfinite(row.e_d())) << row.name();
    EXPECT_GT(row.e_held_out(), 0.0) << row.name();
    EXPECT_GT(row.seconds(), 0.0);
  }
  EXPECT_EQ(report->chosen_configuration(), "NE,NW,SE,SW");
  EXPECT_EQ(report->configuration_criterion(), "held-out");
  // Table 7.1: the correction atlases lower every camera's error.
  ASSERT_EQ(report->cameras_size(), 8);
  for (const auto& row : report->cameras()) {
    EXPECT_LT(row.mse_correction(), row.mse_brdf()) << row.name();
    EXPECT_GT(row.samples(), 0u);
  }
  // The Powell comparison was not requested; light refinement is skipped in
  // auto (plan.cc says why); normals were not asked for (issue #18).
  EXPECT_EQ(report->plan().skipped_size(), 3);

  auto evaluation = evaluate::EvaluateReconstruction(dir_ / "run", dir_ / "bundle");
  ASSERT_TRUE(evaluation.ok()) << evaluation.status();
  EXPECT_TRUE(evaluation->configuration_correct());
  EXPECT_LE(evaluation->kd_rmse(), kMaxKdRmse);
  EXPECT_GT(evaluation->kd_texels(), 10000u);
  EXPECT_GE(evaluation->cluster_accuracy(), kMinClusterAccuracy);
  ASSERT_EQ(evaluation->clusters_size(), 3);
  for (const auto& c : evaluation->clusters()) {
    SCOPED_TRACE(c.cluster());
    EXPECT_EQ(c.material(), c.cluster());  // seeds named after the materials
    EXPECT_LE(c.ks_rel_error(), kMaxKsRelError);
    EXPECT_LE(c.ke_rel_error(), kMaxKeRelError);
  }

  // The atlases and one correction atlas per frame are on disk.
  for (const char* f : {"result.json", "atlases/kd.exr", "atlases/ks.exr", "atlases/ke.exr", "atlases/cluster.exr",
                        "atlases/confidence.exr", "atlases/kd.png", "atlases/correction/0011.exr", "atlas/mesh.obj"}) {
    EXPECT_TRUE(std::filesystem::exists(dir_ / "run" / f)) << f;
  }
  EXPECT_FALSE(std::filesystem::exists(dir_ / "run" / "atlases" / "observed_kd.tmp"));
}

TEST_F(ReconstructStageTest, LightTableOnlyComputesNothingElse) {
  auto sequence = scene::LoadSequence(dir_ / "bundle" / "scene.json");
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  ReconstructOptions options;
  options.request.brdf_atlases = options.request.correction = options.request.camera_errors = false;
  options.sweep_frame_stride = 3;  // every third frame is enough to fill the table
  options.out_dir = dir_ / "light_only";
  // Issue #19 defect 8: the one-process sweep fitted all 8 configurations
  // whatever the request's candidates said. It sweeps those, in order.
  options.request.candidates = {"C", "NE,NW,SE,SW", "N,E,W,S"};
  auto report = RunReconstruction(*sequence, *context_, options);
  ASSERT_TRUE(report.ok()) << report.status();
  ASSERT_EQ(report->light_configurations_size(), 3);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(report->light_configurations(i).name(), options.request.candidates[i]);
  std::string why;
  for (const v1::PlannedStage& stage : report->plan().stages()) {
    if (stage.name() == "light_sweep") why = stage.why();
  }
  EXPECT_EQ(why.rfind("3 candidate configurations (of the scene's 8)", 0), 0u) << why;
  // What the run ran on, for `mvbrdf evaluate`.
  EXPECT_EQ(report->input().mesh_triangles(), sequence->topology.triangles.size());
  EXPECT_EQ(report->input().cameras_size(), static_cast<int>(sequence->cameras.size()));
  EXPECT_EQ(report->clusters_size(), 0);
  EXPECT_EQ(report->cameras_size(), 0);
  EXPECT_FALSE(std::filesystem::exists(dir_ / "light_only" / "atlases"));
}

// Issue #15 item 2: gathering the half-vector geometry into the Samples (for
// the models other than Phong) leaves the Phong path's results as they were:
// the thesis's Table 6.1 (E_a, E_d, the held-out error of every candidate),
// the choice, the cluster fits and Table 7.1, to 1e-6 relative. (The two runs
// share code and data up to what the Samples store; a difference would come
// from the geometry changing which Samples the fits see.)
TEST_F(ReconstructStageTest, HalfVectorGeometryLeavesThePhongTablesUnchanged) {
  auto sequence = scene::LoadSequence(dir_ / "bundle" / "scene.json");
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  auto run = [&](bool half_vector, const char* name) {
    ReconstructOptions options;
    options.request.compare_solvers = false;
    options.request.correction = false;
    options.request.candidates = {"NE,NW,SE,SW", "N,E,W,S"};
    options.atlas.size = 128;
    options.sweep_frame_stride = 3;
    options.half_vector_geometry = half_vector;
    options.out_dir = dir_ / name;
    return RunReconstruction(*sequence, *context_, options);
  };
  auto phong = run(false, "phong_samples");
  ASSERT_TRUE(phong.ok()) << phong.status();
  auto half_vector = run(true, "half_vector_samples");
  ASSERT_TRUE(half_vector.ok()) << half_vector.status();
  const auto near = [](double a, double b) { return std::abs(a - b) <= 1e-6 * std::max(std::abs(a), std::abs(b)); };
  ASSERT_EQ(phong->light_configurations_size(), 2);
  ASSERT_EQ(half_vector->light_configurations_size(), 2);
  for (int i = 0; i < 2; ++i) {
    const auto& a = phong->light_configurations(i);
    const auto& b = half_vector->light_configurations(i);
    EXPECT_TRUE(near(a.e_a(), b.e_a())) << a.name() << " " << a.e_a() << " " << b.e_a();
    EXPECT_TRUE(near(a.e_d(), b.e_d())) << a.name() << " " << a.e_d() << " " << b.e_d();
    EXPECT_TRUE(near(a.e_held_out(), b.e_held_out())) << a.name();
  }
  EXPECT_EQ(phong->chosen_configuration(), half_vector->chosen_configuration());
  ASSERT_EQ(phong->clusters_size(), 3);
  ASSERT_EQ(half_vector->clusters_size(), 3);
  for (int k = 0; k < 3; ++k) {
    const auto& a = phong->clusters(k);
    const auto& b = half_vector->clusters(k);
    EXPECT_EQ(a.texels(), b.texels()) << a.name();
    ASSERT_EQ(a.ks_size(), 3);
    ASSERT_EQ(b.ks_size(), 3);
    for (int c = 0; c < 3; ++c) {
      EXPECT_TRUE(near(a.ks(c), b.ks(c))) << a.name() << " " << a.ks(c) << " " << b.ks(c);
      EXPECT_TRUE(near(a.ke(c), b.ke(c))) << a.name() << " " << a.ke(c) << " " << b.ke(c);
    }
  }
  ASSERT_EQ(phong->cameras_size(), half_vector->cameras_size());
  for (int c = 0; c < phong->cameras_size(); ++c) {
    EXPECT_TRUE(near(phong->cameras(c).mse_brdf(), half_vector->cameras(c).mse_brdf())) << phong->cameras(c).name();
  }
}

// Issue #19 defect 7: "mseBrdf": "Infinity" in a SUCCEEDED job. Any
// non-finite figure is an error naming the figure and its row.
TEST(CheckMetricsFiniteTest, NamesTheMetricAndItsRow) {
  v1::RunReport report;
  report.add_light_configurations()->set_name("C");
  v1::CameraErrorRow* cam = report.add_cameras();
  cam->set_name("cam3");
  cam->set_mse_brdf(0.01);
  EXPECT_TRUE(CheckMetricsFinite(report).ok());
  report.add_cameras()->set_name("blind");  // no observation: the MSE is absent, which is fine
  EXPECT_TRUE(CheckMetricsFinite(report).ok());
  cam->set_mse_brdf(std::numeric_limits<double>::infinity());
  absl::Status s = CheckMetricsFinite(report);
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(s.message().find("camera \"cam3\": MSE with the BRDF atlases is inf, not a finite number (input values "
                             "out of range? e.g. light intensities"),
            std::string::npos)
      << s.message();
  cam->set_mse_brdf(0.01);
  report.mutable_light_configurations(0)->set_e_d(std::nan(""));
  EXPECT_NE(CheckMetricsFinite(report).message().find("light configuration \"C\": E_d is nan"), std::string::npos);
  report.mutable_light_configurations(0)->set_e_d(1.0);
  v1::SolverRow* solver = report.add_solvers();
  solver->set_cluster("skin");
  solver->set_solver("powell");
  for (double v : {0.1, std::numeric_limits<double>::infinity(), 0.1}) solver->add_ks(v);
  EXPECT_NE(CheckMetricsFinite(report).message().find("cluster \"skin\" (powell): ks[1] is inf"), std::string::npos);
}

}  // namespace
}  // namespace mvbrdf::pipeline
