#include "core/calibrate/refine_cameras.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "absl/strings/str_format.h"
#include "core/base/proto_json.h"
#include "core/calibrate/camera_parameterisation.h"
#include "core/calibrate/depth_map.h"
#include "core/synth/synthesizer.h"
#include "mvbrdf/v1/ground_truth.pb.h"

namespace mvbrdf::calibrate {
namespace {

gl::EglContext* Context() {
  static gl::EglContext* context = [] {
    auto c = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
    EXPECT_TRUE(c.ok()) << c.status();
    return c.ok() ? std::move(c).value().release() : nullptr;
  }();
  return context;
}

// Errors of `cameras` against the truth: rotation (deg), centre (world
// units) and the mean image displacement of the visible surface (px).
struct TruthError {
  double rotation_deg = 0, centre = 0, reprojection_px = 0;
};
TruthError ErrorAgainst(const scene::CameraModel& camera, const scene::CameraModel& truth,
                        const scene::Sequence& sequence) {
  TruthError e;
  e.rotation_deg = RotationAngleDeg(camera, truth);
  e.centre = glm::length(camera.CenterInWorld() - truth.CenterInWorld());
  const DepthMap depth = RenderDepth(truth, sequence.topology.file_triangles, sequence.rest_positions);
  double sum = 0;
  int n = 0;
  for (const glm::uvec3& t : sequence.topology.file_triangles) {
    const glm::dvec3 x = (glm::dvec3(sequence.rest_positions[t.x]) + glm::dvec3(sequence.rest_positions[t.y]) +
                          glm::dvec3(sequence.rest_positions[t.z])) /
                         3.0;
    if (!VisibleAt(depth, truth.Project(x), truth.CamFromWorld(x).z, 0.01)) continue;
    sum += glm::length(camera.Project(x) - truth.Project(x));
    ++n;
  }
  e.reprojection_px = n > 0 ? sum / n : 0;
  return e;
}

struct Outcome {
  std::vector<TruthError> before, after;
  v1::CalibrationReport report;
  double MaxAfter() const {
    double m = 0;
    for (const auto& e : after) m = std::max(m, e.reprojection_px);
    return m;
  }
  double MeanBefore() const {
    double m = 0;
    for (const auto& e : before) m += e.reprojection_px / before.size();
    return m;
  }
  double MeanAfter() const {
    double m = 0;
    for (const auto& e : after) m += e.reprojection_px / after.size();
    return m;
  }
};

Outcome Refine(const scene::Sequence& sequence, const v1::GroundTruth& truth, const CameraRefinementOptions& options) {
  Outcome out;
  auto report = RefineCameras(sequence, *Context(), options);
  EXPECT_TRUE(report.ok()) << report.status();
  if (!report.ok()) return out;
  out.report = *report;
  for (size_t c = 0; c < sequence.cameras.size(); ++c) {
    const scene::CameraModel t = scene::CameraModelFromProto(truth.cameras(static_cast<int>(c)));
    const scene::CameraModel r = scene::CameraModelFromProto(report->cameras(static_cast<int>(c)).camera());
    out.before.push_back(ErrorAgainst(sequence.cameras[c], t, sequence));
    out.after.push_back(ErrorAgainst(r, t, sequence));
    const auto& row = report->cameras(static_cast<int>(c));
    std::printf(
        "%s: truth error rot %.4f -> %.4f deg, centre %.5f -> %.5f, reproj %.3f -> %.3f px | change %.3f px, "
        "rot %.3f+-%.3f deg, centre %.4f+-%.4f, focal %+.5f, k1 %+.5f, photometric %.5f -> %.5f, obs %llu\n",
        row.name().c_str(), out.before.back().rotation_deg, out.after.back().rotation_deg, out.before.back().centre,
        out.after.back().centre, out.before.back().reprojection_px, out.after.back().reprojection_px,
        row.reprojection_change_px(), row.rotation_change_deg(), row.rotation_sigma_deg(), row.centre_change(),
        row.centre_sigma(), row.focal_change(), row.k1_change(), row.residual_before(), row.residual_after(),
        static_cast<unsigned long long>(row.observations()));
  }
  std::printf("refined=%d decision: %s (%.2f s, %u frames)\n", report->cameras_refined(),
              report->cameras_decision().c_str(), report->cameras_seconds(), report->frames_used());
  return out;
}

struct Synthesised {
  scene::Sequence sequence;
  v1::GroundTruth truth;
};

Synthesised Synth(const std::string& name, double rotation_deg, double translation, double k1, uint32_t seed,
                  int width = 160, int height = 120) {
  synth::SynthOptions o;
  o.num_cameras = 6;
  o.num_frames = 4;
  o.width = width;
  o.height = height;
  o.actor_segments = 16;
  o.shadow_map_size = 256;
  o.camera_rotation_error_deg = rotation_deg;
  o.camera_translation_error = translation;
  o.distortion_k1 = k1;
  o.seed = seed;
  o.out_dir = std::filesystem::temp_directory_path() / ("mvbrdf_refine_cameras_test_" + name);
  std::filesystem::remove_all(o.out_dir);
  Synthesised s;
  auto result = synth::Synthesize(o, *Context());
  EXPECT_TRUE(result.ok()) << result.status();
  if (!result.ok()) return s;
  auto sequence = scene::LoadSequence(result->scene_file);
  EXPECT_TRUE(sequence.ok()) << sequence.status();
  auto truth = ReadJsonFileAs<v1::GroundTruth>(o.out_dir / "ground_truth" / "truth.json");
  EXPECT_TRUE(truth.ok()) << truth.status();
  if (!sequence.ok() || !truth.ok()) return s;
  s.sequence = std::move(sequence).value();
  s.truth = *truth;
  return s;
}

TEST(RefineCamerasTest, PerturbedCamerasMoveTowardsTheTruth) {
  const Synthesised s = Synth("rot", 0.4, 0.005, 0.0, 7, 320, 240);
  ASSERT_EQ(s.truth.cameras_size(), 6);
  CameraRefinementOptions options;
  options.frames = 4;
  const Outcome o = Refine(s.sequence, s.truth, options);
  EXPECT_TRUE(o.report.cameras_refined()) << o.report.cameras_decision();
  // Measured: 2.08 -> 0.030 px mean, rotation errors 0.035-0.056 deg.
  EXPECT_LT(o.MeanAfter(), o.MeanBefore() / 10) << "mean reprojection error against the truth, px";
  for (const TruthError& e : o.after) EXPECT_LT(e.rotation_deg, 0.08);
}

TEST(RefineCamerasTest, AutoKeepsAnExactCalibration) {
  const Synthesised s = Synth("clean", 0.0, 0.0, 0.0, 7, 320, 240);
  CameraRefinementOptions options;
  options.frames = 4;
  const Outcome o = Refine(s.sequence, s.truth, options);
  EXPECT_FALSE(o.report.cameras_refined()) << o.report.cameras_decision();
  // What it would change stays small (measured 0.046 px at most).
  EXPECT_LT(o.MaxAfter(), 0.1);
}

// The intrinsics: the scene's focal length 3 % long and its k1 dropped
// (the video has k1 = -0.2) are recovered with --refine-focal/--refine-
// distortion and only absorbed in part by the pose without them.
TEST(RefineCamerasTest, FocalAndDistortionRefinementRecoverTheIntrinsics) {
  Synthesised s = Synth("intrinsics", 0.0, 0.0, -0.2, 11, 320, 240);
  ASSERT_EQ(s.truth.cameras_size(), 6);
  for (scene::CameraModel& camera : s.sequence.cameras) {
    camera.fx *= 1.03;
    camera.fy *= 1.03;
    camera.distortion[0] = 0.0;
  }
  CameraRefinementOptions options;
  options.frames = 4;
  options.mode = v1::REFINEMENT_ON;
  const Outcome pose_only = Refine(s.sequence, s.truth, options);
  options.focal = true;
  options.distortion = true;
  const Outcome with_intrinsics = Refine(s.sequence, s.truth, options);
  ASSERT_EQ(with_intrinsics.report.cameras_size(), 6);
  EXPECT_LT(with_intrinsics.MeanAfter(), 0.5 * pose_only.MeanAfter());
  EXPECT_LT(with_intrinsics.MeanAfter(), 0.25 * with_intrinsics.MeanBefore());
  for (const v1::CameraRefinementRow& row : with_intrinsics.report.cameras()) {
    // fx_true / fx_scene - 1 = 1 / 1.03 - 1 = -0.029.
    EXPECT_NEAR(row.focal_change(), 1.0 / 1.03 - 1.0, 0.005) << row.name();
    EXPECT_NEAR(row.k1_change(), -0.2, 0.1) << row.name();
  }
  for (const v1::CameraRefinementRow& row : pose_only.report.cameras()) {
    EXPECT_EQ(row.focal_change(), 0.0);
    EXPECT_EQ(row.k1_change(), 0.0);
  }
}

// --refine-photometric: the consensus colours of textured points join the
// silhouettes in the solve. The cameras it gives are more consistent across
// views (what the term minimises), differ from the silhouettes' alone and
// still reach the truth. Measured here (2 frames): mean reprojection error
// against the truth 0.052 px with it, 0.031 px without (from 2.08); mean
// photometric rms after 0.0078 with, 0.0085 without.
TEST(RefineCamerasTest, PhotometricTermChangesTheSolveAndReachesTheTruth) {
  const Synthesised s = Synth("photometric", 0.4, 0.005, 0.0, 7, 320, 240);
  ASSERT_EQ(s.truth.cameras_size(), 6);
  CameraRefinementOptions options;
  options.frames = 2;
  options.mode = v1::REFINEMENT_ON;
  const Outcome silhouettes = Refine(s.sequence, s.truth, options);
  options.photometric = true;
  const Outcome both = Refine(s.sequence, s.truth, options);
  ASSERT_EQ(both.report.cameras_size(), 6);
  ASSERT_EQ(silhouettes.report.cameras_size(), 6);
  EXPECT_LT(both.MeanAfter(), both.MeanBefore() / 10) << "mean reprojection error against the truth, px";
  double moved = 0;
  for (int c = 0; c < 6; ++c) {
    moved = std::max(moved, std::fabs(both.after[static_cast<size_t>(c)].reprojection_px -
                                      silhouettes.after[static_cast<size_t>(c)].reprojection_px));
  }
  EXPECT_GT(moved, 1e-4) << "the photometric term changes no camera";
  double rms_silhouettes = 0, rms_both = 0;
  for (int c = 0; c < 6; ++c) {
    rms_silhouettes += silhouettes.report.cameras(c).residual_after() / 6;
    rms_both += both.report.cameras(c).residual_after() / 6;
  }
  EXPECT_LT(rms_both, rms_silhouettes) << "cross-camera photometric rms after refinement";
}

}  // namespace
}  // namespace mvbrdf::calibrate

namespace mvbrdf::calibrate {
namespace {

// A measurement on a synthetic bundle, not part of the suite: set
// MVBRDF_REFINE_SCENE=DIR (a `mvbrdf synth` output); MVBRDF_REFINE_OUT=FILE
// writes the scene with the refined cameras.
TEST(RefineCamerasTest, MeasureExternalScene) {
  const char* dir = std::getenv("MVBRDF_REFINE_SCENE");
  if (dir == nullptr) GTEST_SKIP() << "MVBRDF_REFINE_SCENE not set";
  auto sequence = scene::LoadSequence(std::filesystem::path(dir) / "scene.json");
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  auto truth = ReadJsonFileAs<v1::GroundTruth>(std::filesystem::path(dir) / "ground_truth" / "truth.json");
  ASSERT_TRUE(truth.ok()) << truth.status();
  CameraRefinementOptions options;
  options.mode = std::getenv("MVBRDF_REFINE_ON") ? v1::REFINEMENT_ON : v1::REFINEMENT_AUTO;
  options.focal = std::getenv("MVBRDF_REFINE_FOCAL") != nullptr;
  options.distortion = std::getenv("MVBRDF_REFINE_K1") != nullptr;
  const Outcome o = Refine(*sequence, *truth, options);
  std::printf("mean reprojection error against the truth: %.3f -> %.3f px\n", o.MeanBefore(), o.MeanAfter());
  if (const char* out = std::getenv("MVBRDF_REFINE_OUT")) {
    scene::Sequence refined = *sequence;
    v1::CalibrationReport report = o.report;
    report.set_cameras_refined(true);
    ASSERT_TRUE(ApplyCameraRefinement(report, &refined).ok());
    ASSERT_TRUE(WriteJsonFile(out, refined.scene).ok());
  }
}

}  // namespace
}  // namespace mvbrdf::calibrate
