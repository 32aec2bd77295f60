#include "core/synth/synthesizer.h"

#include <gtest/gtest.h>

#include "core/base/proto_json.h"
#include "core/render/phong_renderer.h"
#include "core/scene/sequence.h"
#include "core/scene/video_source.h"
#include "core/synth/frame_encoder.h"
#include "core/synth/subject.h"

namespace mvbrdf::synth {
namespace {

class SynthesizerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
    ASSERT_TRUE(context.ok()) << context.status();
    context_ = std::move(context).value().release();
  }
  static void TearDownTestSuite() {
    delete context_;
    context_ = nullptr;
  }

  static SynthOptions SmallOptions(const std::string& name) {
    SynthOptions o;
    o.num_cameras = 2;
    o.num_frames = 3;
    o.width = 96;
    o.height = 72;
    o.actor_segments = 12;
    o.shadow_map_size = 256;
    o.noise_sigma = 0.0;
    o.out_dir = std::filesystem::temp_directory_path() / ("mvbrdf_synth_test_" + name);
    std::filesystem::remove_all(o.out_dir);
    return o;
  }

  static gl::EglContext* context_;
};

gl::EglContext* SynthesizerTest::context_ = nullptr;

TEST_F(SynthesizerTest, SmallSequenceLoadsBackAndValidates) {
  const SynthOptions o = SmallOptions("roundtrip");
  auto result = Synthesize(o, *context_);
  ASSERT_TRUE(result.ok()) << result.status();
  auto sequence = scene::LoadSequence(result->scene_file);
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  EXPECT_EQ(sequence->num_frames, 3);
  EXPECT_EQ(sequence->cameras.size(), 2u);
  EXPECT_EQ(sequence->lights.size(), 9u);
  EXPECT_EQ(sequence->scene.light_configurations_size(), 8);
  EXPECT_EQ(sequence->scene.material_seeds_size(), 3);
  EXPECT_EQ(static_cast<int>(sequence->topology.triangles.size()), result->num_triangles);
  EXPECT_TRUE(sequence->topology.zero_area_triangles.empty());

  auto truth = ReadJsonFileAs<v1::GroundTruth>(o.out_dir / "ground_truth" / "truth.json");
  ASSERT_TRUE(truth.ok()) << truth.status();
  EXPECT_EQ(truth->active_configuration(), "NE,NW,SE,SW");
  EXPECT_EQ(truth->lights_size(), 4);
  EXPECT_EQ(truth->materials_size(), 3);
  EXPECT_EQ(truth->triangle_materials_size(), result->num_triangles);
  EXPECT_EQ(truth->cameras_size(), 2);
  // The frames move: frame 2's mesh differs from frame 0's.
  auto f2 = sequence->LoadFrame(2);
  ASSERT_TRUE(f2.ok()) << f2.status();
  EXPECT_NE((*f2)[0], sequence->rest_positions[0]);
}

// The videos hold exactly what the truth describes: re-rendering from the
// truth (cameras, lights, materials) and encoding gives the decoded frames
// bit for bit (FFV1 is lossless and noise is off).
TEST_F(SynthesizerTest, VideoFramesMatchARenderOfTheTruth) {
  const SynthOptions o = SmallOptions("truth");
  auto result = Synthesize(o, *context_);
  ASSERT_TRUE(result.ok()) << result.status();
  auto sequence = scene::LoadSequence(result->scene_file);
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  const v1::GroundTruth& truth = result->truth;

  render::RenderMesh mesh;
  mesh.triangles = sequence->topology.triangles;
  mesh.rest_positions = scene::ToRenderVertices(sequence->topology, sequence->rest_positions);
  mesh.triangle_material.assign(truth.triangle_materials().begin(), truth.triangle_materials().end());
  render::RendererOptions ro;
  ro.shadow_map_size = static_cast<int>(truth.shadow_map_size());
  auto renderer = render::PhongRenderer::Create(*context_, mesh, ro);
  ASSERT_TRUE(renderer.ok()) << renderer.status();
  std::vector<render::ProceduralMaterial> materials;
  for (const v1::Material& m : truth.materials()) {
    render::ProceduralMaterial pm;
    pm.kd.base = {m.kd().base(0), m.kd().base(1), m.kd().base(2)};
    pm.kd.amplitude = static_cast<float>(m.kd().amplitude());
    pm.kd.frequency = static_cast<float>(m.kd().frequency());
    pm.kd.offset = {m.kd().offset(0), m.kd().offset(1), m.kd().offset(2)};
    pm.ks = {m.ks(0), m.ks(1), m.ks(2)};
    pm.ke = {m.ke(0), m.ke(1), m.ke(2)};
    materials.push_back(pm);
  }
  ASSERT_TRUE((*renderer)->SetProceduralMaterials(materials).ok());
  std::vector<scene::Light> lights;
  for (const v1::Light& l : truth.lights()) {
    scene::Light light;
    light.name = l.name();
    light.position = {l.position(0), l.position(1), l.position(2)};
    light.intensity = {l.intensity(0), l.intensity(1), l.intensity(2)};
    lights.push_back(light);
  }
  ASSERT_TRUE((*renderer)->SetLights(lights).ok());

  for (int c = 0; c < 2; ++c) {
    auto video = scene::VideoSource::Open(sequence->scene.cameras(c), sequence->scene_dir, 0, "camera");
    ASSERT_TRUE(video.ok()) << video.status();
    const scene::CameraModel true_camera = scene::CameraModelFromProto(truth.cameras(c));
    for (int t = 0; t < 3; ++t) {
      auto positions = sequence->LoadFrame(t);
      ASSERT_TRUE(positions.ok());
      render::Pose pose;
      pose.positions = scene::ToRenderVertices(sequence->topology, *positions);
      pose.normals = scene::ToRenderVertices(sequence->topology,
                                             scene::ComputeFileVertexNormals(sequence->topology, *positions));
      auto image = (*renderer)->Render(pose, true_camera);
      ASSERT_TRUE(image.ok()) << image.status();
      std::mt19937 rng(1);
      const cv::Mat expected = EncodeSrgb8(image->radiance, {}, rng);
      auto frame = (*video)->ReadFrame(t);
      ASSERT_TRUE(frame.ok()) << frame.status();
      // Re-encode the decoded linear frame to 8 bits to compare code values.
      const cv::Mat decoded = EncodeSrgb8(*frame, {}, rng);
      cv::Mat diff;
      cv::absdiff(expected, decoded, diff);
      double max_diff = 0.0;
      cv::minMaxLoc(diff.reshape(1), nullptr, &max_diff);
      EXPECT_EQ(max_diff, 0.0) << "camera " << c << " frame " << t;
      // And the subject is visible, not black.
      EXPECT_GT(cv::countNonZero(expected.reshape(1)), expected.rows * expected.cols / 20);
    }
  }
}

TEST_F(SynthesizerTest, CalibrationErrorChangesOnlyTheScenesCameras) {
  SynthOptions o = SmallOptions("calibration");
  o.num_frames = 1;
  o.camera_rotation_error_deg = 1.0;
  o.camera_translation_error = 0.02;
  o.video_format = VideoFormat::kPng;
  auto result = Synthesize(o, *context_);
  ASSERT_TRUE(result.ok()) << result.status();
  auto sequence = scene::LoadSequence(result->scene_file);
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  EXPECT_NE(sequence->scene.cameras(0).video().path().find("%04d.png"), std::string::npos);
  const scene::CameraModel truth_cam = scene::CameraModelFromProto(result->truth.cameras(0));
  const double moved = glm::length(sequence->cameras[0].CenterInWorld() - truth_cam.CenterInWorld());
  EXPECT_NEAR(moved, 0.02, 1e-6);
  EXPECT_NEAR(result->truth.perturbations().camera_rotation_error_deg(), 1.0, 0.0);
}

TEST_F(SynthesizerTest, BadOptionsNameTheFlag) {
  SynthOptions o = SmallOptions("bad");
  o.configuration = "NE,XX";
  auto result = Synthesize(o, *context_);
  EXPECT_EQ(result.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(result.status().message().find("--config"), std::string::npos);
  o = SmallOptions("bad2");
  o.num_cameras = 0;
  EXPECT_NE(Synthesize(o, *context_).status().message().find("--cameras"), std::string::npos);
}

}  // namespace
}  // namespace mvbrdf::synth
