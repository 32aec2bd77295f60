#include "core/synth/synthesizer.h"

#include <cstdio>
#include <set>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "core/base/files.h"
#include "core/base/proto_json.h"
#include "core/render/phong_renderer.h"
#include "core/scene/sequence.h"
#include "core/scene/video_source.h"
#include "core/synth/frame_encoder.h"
#include "core/synth/ground_truth.h"
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
  auto truth = GroundTruth::Load(o.out_dir / "ground_truth" / "truth.json");
  ASSERT_TRUE(truth.ok()) << truth.status();

  render::RenderMesh mesh;
  mesh.triangles = sequence->topology.triangles;
  mesh.rest_positions = scene::ToRenderVertices(sequence->topology, sequence->rest_positions);
  mesh.triangle_material.assign(truth->message().triangle_materials().begin(),
                                truth->message().triangle_materials().end());
  render::RendererOptions ro;
  ro.shadow_map_size = static_cast<int>(truth->message().shadow_map_size());
  auto renderer = render::PhongRenderer::Create(*context_, mesh, ro);
  ASSERT_TRUE(renderer.ok()) << renderer.status();
  ASSERT_TRUE((*renderer)->SetProceduralMaterials(truth->RendererMaterials()).ok());
  ASSERT_TRUE((*renderer)->SetLights(truth->ActiveLights()).ok());
  const std::vector<scene::CameraModel> true_cameras = truth->Cameras();

  for (int c = 0; c < 2; ++c) {
    auto video = scene::VideoSource::Open(sequence->scene.cameras(c), sequence->scene_dir, 0, "camera");
    ASSERT_TRUE(video.ok()) << video.status();
    const scene::CameraModel& true_camera = true_cameras[c];
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

// Issue #13: --lighting olat lights frame t by the studio's light t mod 9
// alone, says so in the scene (frame_lighting) and the truth, and the videos
// hold exactly that: a render of the truth under FrameLights(t), not under
// every light.
TEST_F(SynthesizerTest, OlatLightsEachFrameByOneLightAndRecordsIt) {
  SynthOptions o = SmallOptions("olat");
  o.num_cameras = 1;
  o.lighting = Lighting::kOlat;
  auto result = Synthesize(o, *context_);
  ASSERT_TRUE(result.ok()) << result.status();
  auto sequence = scene::LoadSequence(result->scene_file);
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  ASSERT_EQ(sequence->scene.frame_lighting_size(), 3);
  EXPECT_TRUE(sequence->every_frame_lit_own());
  const std::vector<std::string> expected_lights = {"C", "N", "E"};  // the studio's first three
  for (int t = 0; t < 3; ++t) {
    const v1::FrameLighting* fl = sequence->FrameLightingOf(t);
    ASSERT_NE(fl, nullptr) << t;
    EXPECT_EQ(std::vector<std::string>(fl->lights().begin(), fl->lights().end()),
              std::vector<std::string>{expected_lights[t]});
  }
  auto truth = GroundTruth::Load(o.out_dir / "ground_truth" / "truth.json");
  ASSERT_TRUE(truth.ok()) << truth.status();
  EXPECT_EQ(truth->message().active_configuration(), scene::kPerFrameLighting);
  EXPECT_EQ(truth->message().lights_size(), 9);
  ASSERT_EQ(truth->message().frame_lighting_size(), 3);
  EXPECT_EQ(truth->message().frame_lighting(1).lights(0), "N");
  ASSERT_EQ(truth->FrameLights(1).size(), 1u);
  EXPECT_EQ(truth->FrameLights(1)[0].name, "N");

  render::RenderMesh mesh;
  mesh.triangles = sequence->topology.triangles;
  mesh.rest_positions = scene::ToRenderVertices(sequence->topology, sequence->rest_positions);
  mesh.triangle_material.assign(truth->message().triangle_materials().begin(),
                                truth->message().triangle_materials().end());
  render::RendererOptions ro;
  ro.shadow_map_size = static_cast<int>(truth->message().shadow_map_size());
  auto renderer = render::PhongRenderer::Create(*context_, mesh, ro);
  ASSERT_TRUE(renderer.ok()) << renderer.status();
  ASSERT_TRUE((*renderer)->SetProceduralMaterials(truth->RendererMaterials()).ok());
  auto video = scene::VideoSource::Open(sequence->scene.cameras(0), sequence->scene_dir, 0, "camera");
  ASSERT_TRUE(video.ok()) << video.status();
  const scene::CameraModel true_camera = truth->Cameras()[0];
  const auto max_difference = [](const cv::Mat& a, const cv::Mat& b) {
    cv::Mat diff;
    cv::absdiff(a, b, diff);
    double m = 0.0;
    cv::minMaxLoc(diff.reshape(1), nullptr, &m);
    return m;
  };
  for (int t = 0; t < 3; ++t) {
    auto positions = sequence->LoadFrame(t);
    ASSERT_TRUE(positions.ok());
    render::Pose pose;
    pose.positions = scene::ToRenderVertices(sequence->topology, *positions);
    pose.normals =
        scene::ToRenderVertices(sequence->topology, scene::ComputeFileVertexNormals(sequence->topology, *positions));
    std::mt19937 rng(1);
    auto frame = (*video)->ReadFrame(t);
    ASSERT_TRUE(frame.ok()) << frame.status();
    const cv::Mat decoded = EncodeSrgb8(*frame, {}, rng);
    ASSERT_TRUE((*renderer)->SetLights(truth->FrameLights(static_cast<uint32_t>(t))).ok());
    auto own = (*renderer)->Render(pose, true_camera);
    ASSERT_TRUE(own.ok()) << own.status();
    EXPECT_EQ(max_difference(EncodeSrgb8(own->radiance, {}, rng), decoded), 0.0) << "frame " << t;
    ASSERT_TRUE((*renderer)->SetLights(truth->ActiveLights()).ok());
    auto all = (*renderer)->Render(pose, true_camera);
    ASSERT_TRUE(all.ok()) << all.status();
    EXPECT_GT(max_difference(EncodeSrgb8(all->radiance, {}, rng), decoded), 10.0) << "frame " << t;
  }
}

// Issue #13: --preset sphere --dome 20 --lighting olat: a closed sphere of
// one material, 20 directional lights over the upper hemisphere named D000..,
// frame t lit by dome light t mod 20 (in the scene and the truth), and each
// video frame a render of the truth under that light. With every light on
// (--lighting studio, 20 lights: two renderer passes) the video is the render
// of the truth's 20 lights.
TEST_F(SynthesizerTest, SphereUnderADomeOfDirectionalLights) {
  for (const Lighting lighting : {Lighting::kOlat, Lighting::kStudio}) {
    SynthOptions o = SmallOptions(lighting == Lighting::kOlat ? "dome_olat" : "dome_studio");
    o.preset = Preset::kSphere;
    o.num_cameras = 1;
    o.dome = 20;
    o.lighting = lighting;
    auto result = Synthesize(o, *context_);
    ASSERT_TRUE(result.ok()) << result.status();
    auto sequence = scene::LoadSequence(result->scene_file);
    ASSERT_TRUE(sequence.ok()) << sequence.status();
    ASSERT_EQ(sequence->lights.size(), 20u);
    for (size_t k = 0; k < 20; ++k) {
      const scene::Light& l = sequence->lights[k];
      char name[8];
      std::snprintf(name, sizeof(name), "D%03d", static_cast<int>(k));
      EXPECT_EQ(l.name, name);
      EXPECT_TRUE(l.directional);
      EXPECT_NEAR(glm::length(l.direction), 1.0f, 1e-6f);
      EXPECT_GT(l.direction.y, 0.0f);  // the upper hemisphere (y up)
    }
    // A closed sphere of radius 0.5: every vertex at 0.5 from the centre, one material.
    glm::vec3 center(0.0f);
    for (const glm::vec3& p : sequence->rest_positions) center += p;
    center /= static_cast<float>(sequence->rest_positions.size());
    for (const glm::vec3& p : sequence->rest_positions) EXPECT_NEAR(glm::length(p - center), 0.5f, 1e-5f);
    auto truth = GroundTruth::Load(o.out_dir / "ground_truth" / "truth.json");
    ASSERT_TRUE(truth.ok()) << truth.status();
    EXPECT_EQ(truth->message().preset(), "sphere");
    ASSERT_EQ(truth->message().materials_size(), 1);
    EXPECT_EQ(truth->ActiveLights().size(), 20u);
    EXPECT_TRUE(truth->ActiveLights()[7].directional);
    if (lighting == Lighting::kOlat) {
      ASSERT_EQ(sequence->scene.frame_lighting_size(), 3);
      EXPECT_EQ(truth->message().active_configuration(), scene::kPerFrameLighting);
      EXPECT_EQ(truth->FrameLights(2).size(), 1u);
      EXPECT_EQ(truth->FrameLights(2)[0].name, "D002");
    } else {
      EXPECT_EQ(sequence->scene.frame_lighting_size(), 0);
      EXPECT_EQ(truth->message().active_configuration(), "all");
    }

    render::RenderMesh mesh;
    mesh.triangles = sequence->topology.triangles;
    mesh.rest_positions = scene::ToRenderVertices(sequence->topology, sequence->rest_positions);
    mesh.triangle_material.assign(truth->message().triangle_materials().begin(),
                                  truth->message().triangle_materials().end());
    render::RendererOptions ro;
    ro.shadow_map_size = static_cast<int>(truth->message().shadow_map_size());
    auto renderer = render::PhongRenderer::Create(*context_, mesh, ro);
    ASSERT_TRUE(renderer.ok()) << renderer.status();
    ASSERT_TRUE((*renderer)->SetProceduralMaterials(truth->RendererMaterials()).ok());
    auto video = scene::VideoSource::Open(sequence->scene.cameras(0), sequence->scene_dir, 0, "camera");
    ASSERT_TRUE(video.ok()) << video.status();
    for (int t = 0; t < 3; ++t) {
      auto positions = sequence->LoadFrame(t);
      ASSERT_TRUE(positions.ok());
      render::Pose pose;
      pose.positions = scene::ToRenderVertices(sequence->topology, *positions);
      pose.normals =
          scene::ToRenderVertices(sequence->topology, scene::ComputeFileVertexNormals(sequence->topology, *positions));
      ASSERT_TRUE((*renderer)
                      ->SetLights(lighting == Lighting::kOlat ? truth->FrameLights(static_cast<uint32_t>(t))
                                                              : truth->ActiveLights())
                      .ok());
      auto image = (*renderer)->Render(pose, truth->Cameras()[0]);
      ASSERT_TRUE(image.ok()) << image.status();
      std::mt19937 rng(1);
      const cv::Mat expected = EncodeSrgb8(image->radiance, {}, rng);
      auto frame = (*video)->ReadFrame(t);
      ASSERT_TRUE(frame.ok()) << frame.status();
      cv::Mat diff;
      cv::absdiff(expected, EncodeSrgb8(*frame, {}, rng), diff);
      double max_diff = 0.0;
      cv::minMaxLoc(diff.reshape(1), nullptr, &max_diff);
      EXPECT_EQ(max_diff, 0.0) << "frame " << t;
      // Not black (an OLAT frame may be lit from behind the camera: D002 is).
      if (lighting == Lighting::kStudio || t == 0) {
        EXPECT_GT(cv::countNonZero(expected.reshape(1)), expected.rows * expected.cols / 20) << "frame " << t;
      }
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

// Issue #14: --light-direction-error turns each directional light of the
// scene by that angle from the rendered one (the truth's), and is recorded.
TEST_F(SynthesizerTest, LightDirectionErrorTurnsEachDirectionalLightOfTheScene) {
  SynthOptions o = SmallOptions("light_direction");
  o.preset = Preset::kSphere;
  o.num_cameras = 1;
  o.num_frames = 1;
  o.dome = 6;
  o.light_direction_error_deg = 5.0;
  auto result = Synthesize(o, *context_);
  ASSERT_TRUE(result.ok()) << result.status();
  auto sequence = scene::LoadSequence(result->scene_file);
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  auto truth = GroundTruth::Load(o.out_dir / "ground_truth" / "truth.json");
  ASSERT_TRUE(truth.ok()) << truth.status();
  EXPECT_DOUBLE_EQ(truth->message().perturbations().light_direction_error_deg(), 5.0);
  const std::vector<scene::Light> rendered = truth->ActiveLights();
  ASSERT_EQ(rendered.size(), 6u);
  ASSERT_EQ(sequence->lights.size(), 6u);
  for (size_t k = 0; k < 6; ++k) {
    ASSERT_EQ(sequence->lights[k].name, rendered[k].name);
    const double cosine = glm::dot(glm::normalize(glm::dvec3(sequence->lights[k].direction)),
                                   glm::normalize(glm::dvec3(rendered[k].direction)));
    EXPECT_NEAR(std::acos(std::min(1.0, cosine)) * 180.0 / 3.14159265358979, 5.0, 1e-3) << rendered[k].name;
    EXPECT_EQ(sequence->lights[k].intensity, rendered[k].intensity);  // no intensity error asked
  }
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
  o = SmallOptions("bad3");
  o.dome = -1;
  EXPECT_NE(Synthesize(o, *context_).status().message().find("--dome"), std::string::npos);
  o = SmallOptions("bad4");
  o.dome = 4;
  o.configuration = "D001,NE";  // a ceiling light's name with a dome
  auto no_such_light = Synthesize(o, *context_);
  EXPECT_EQ(no_such_light.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(no_such_light.status().message().find("--config: no dome light \"NE\""), std::string::npos);
}

std::filesystem::path SharedData() { return MVBRDF_SHARED_DATA_DIR; }

TEST_F(SynthesizerTest, SpotPresetUsesItsTextureAsKd) {
  if (!std::filesystem::exists(SharedData() / "spot")) GTEST_SKIP() << "no ../shared/data/spot in this checkout";
  SynthOptions o = SmallOptions("spot");
  o.preset = Preset::kSpot;
  o.data_dir = SharedData();
  o.num_frames = 2;
  auto result = Synthesize(o, *context_);
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(result->num_triangles, 5856);
  EXPECT_EQ(result->truth.materials(0).kd_texture_path(), "kd_texture.png");
  EXPECT_TRUE(std::filesystem::exists(o.out_dir / "ground_truth" / "kd_texture.png"));
  auto sequence = scene::LoadSequence(result->scene_file);
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  EXPECT_TRUE(sequence->topology.has_uvs());
}

TEST_F(SynthesizerTest, SambaPresetReadsTheRealPerformance) {
  if (!std::filesystem::exists(SharedData() / "samba")) GTEST_SKIP() << "no ../shared/data/samba in this checkout";
  SynthOptions o = SmallOptions("samba");
  o.preset = Preset::kSamba;
  o.data_dir = SharedData();
  o.num_cameras = 1;
  o.num_frames = 2;
  auto result = Synthesize(o, *context_);
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(result->num_triangles, 19938);
  auto sequence = scene::LoadSequence(result->scene_file);
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  EXPECT_FALSE(sequence->topology.has_uvs());
  // All three materials occur (hair on top, skin on the face, cloth below).
  std::set<uint32_t> materials(result->truth.triangle_materials().begin(), result->truth.triangle_materials().end());
  EXPECT_EQ(materials.size(), 3u);
  o.num_frames = 176;
  EXPECT_NE(Synthesize(o, *context_).status().message().find("--frames"), std::string::npos);
}

// Mean absolute 8-bit difference between camera 0's frame 0 of two bundles.
double MeanFrameDifference(const std::filesystem::path& a, const std::filesystem::path& b) {
  auto sa = scene::LoadSequence(a / "scene.json");
  auto sb = scene::LoadSequence(b / "scene.json");
  EXPECT_TRUE(sa.ok() && sb.ok());
  auto va = scene::VideoSource::Open(sa->scene.cameras(0), sa->scene_dir, 0, "a");
  auto vb = scene::VideoSource::Open(sb->scene.cameras(0), sb->scene_dir, 0, "b");
  EXPECT_TRUE(va.ok() && vb.ok());
  auto fa = (*va)->ReadFrame(0);
  auto fb = (*vb)->ReadFrame(0);
  EXPECT_TRUE(fa.ok() && fb.ok());
  cv::Mat diff;
  cv::absdiff(*fa, *fb, diff);
  return cv::mean(diff.reshape(1))[0];
}

double ClippedFraction(const std::filesystem::path& bundle) {
  auto s = scene::LoadSequence(bundle / "scene.json");
  auto v = scene::VideoSource::Open(s->scene.cameras(0), s->scene_dir, 0, "a");
  auto f = (*v)->ReadFrame(0);
  // Of the channels the subject lights (not background), the share at full
  // scale: the decoder marks a saturated pixel (video.saturationLevel, the top
  // code by default) negative, every channel.
  const cv::Mat channels = f->reshape(1);
  const int lit = cv::countNonZero(channels > 0.0f) + cv::countNonZero(channels < 0.0f);
  return (cv::countNonZero(channels >= 0.999f) + cv::countNonZero(channels < 0.0f)) / static_cast<double>(std::max(lit, 1));
}

TEST_F(SynthesizerTest, PerturbationsChangeTheImagesAndAreRecorded) {
  SynthOptions base = SmallOptions("clean");
  base.num_frames = 1;
  ASSERT_TRUE(Synthesize(base, *context_).ok());

  SynthOptions lossy = SmallOptions("lossy");
  lossy.num_frames = 1;
  lossy.lossy_video = true;
  auto lossy_result = Synthesize(lossy, *context_);
  ASSERT_TRUE(lossy_result.ok()) << lossy_result.status();
  EXPECT_TRUE(lossy_result->truth.perturbations().lossy_video());
  EXPECT_GT(MeanFrameDifference(base.out_dir, lossy.out_dir), 1e-4);

  SynthOptions bumpy = SmallOptions("bumpy");
  bumpy.num_frames = 1;
  bumpy.vertex_noise = 0.02;
  auto bumpy_result = Synthesize(bumpy, *context_);
  ASSERT_TRUE(bumpy_result.ok()) << bumpy_result.status();
  EXPECT_DOUBLE_EQ(bumpy_result->truth.perturbations().vertex_noise(), 0.02);
  EXPECT_GT(MeanFrameDifference(base.out_dir, bumpy.out_dir), 1e-4);
  // The scene's mesh stays clean: the same file as without the noise.
  EXPECT_EQ(*ReadFileToString(base.out_dir / "meshes" / "mesh_0000.obj"),
            *ReadFileToString(bumpy.out_dir / "meshes" / "mesh_0000.obj"));

  SynthOptions bright = SmallOptions("bright");
  bright.num_frames = 1;
  bright.exposure = 8.0;
  ASSERT_TRUE(Synthesize(bright, *context_).ok());
  EXPECT_LT(ClippedFraction(base.out_dir), 0.01);
  EXPECT_GT(ClippedFraction(bright.out_dir), 0.1);

  SynthOptions noisy = SmallOptions("noisy");
  noisy.num_frames = 1;
  noisy.noise_sigma = 3.0;
  ASSERT_TRUE(Synthesize(noisy, *context_).ok());
  EXPECT_GT(MeanFrameDifference(base.out_dir, noisy.out_dir), 1e-4);

  SynthOptions distorted = SmallOptions("distorted");
  distorted.num_frames = 1;
  distorted.distortion_k1 = -0.1;
  auto distorted_result = Synthesize(distorted, *context_);
  ASSERT_TRUE(distorted_result.ok()) << distorted_result.status();
  auto s = scene::LoadSequence(distorted_result->scene_file);
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_DOUBLE_EQ(s->cameras[0].distortion[0], -0.1);
  EXPECT_GT(MeanFrameDifference(base.out_dir, distorted.out_dir), 1e-4);
}

// --pixel-samples: a pixel is the mean of what it sees, as on a sensor. The
// truth of a pixel's value is the integral over its area; 8 x 8 samples
// stand for it here. One sample at the centre (aliased silhouettes) is far
// from it, 4 x 4 close, and the number is recorded in the truth.
TEST_F(SynthesizerTest, PixelSamplesAverageEachPixelsArea) {
  const auto render = [&](int samples) {
    SynthOptions o = SmallOptions("pixel_samples_" + std::to_string(samples));
    o.num_frames = 1;
    o.num_cameras = 1;
    o.pixel_samples = samples;
    auto result = Synthesize(o, *context_);
    EXPECT_TRUE(result.ok()) << result.status();
    if (result.ok()) {
      EXPECT_EQ(result->truth.perturbations().pixel_samples(), static_cast<uint32_t>(samples));
    }
    return o.out_dir;
  };
  const auto one = render(1), four = render(4), reference = render(8);
  const double one_off = MeanFrameDifference(one, reference), four_off = MeanFrameDifference(four, reference);
  // Measured (96x72, linear, mean over the image, most of it background):
  // 0.00108 and 0.00012.
  std::printf("mean difference from 8 x 8 samples: 1 sample %.6f, 4 x 4 %.6f\n", one_off, four_off);
  EXPECT_GT(one_off, 2e-4);
  EXPECT_LT(four_off, 0.3 * one_off);
}

// The first camera's first frame as written equals the truth drawn again by
// the renderer from truth.json alone (materials, measured networks, lights,
// cameras), to the 8-bit code value.
void ExpectFirstFrameIsTheTruthRendered(gl::EglContext& context, const SynthResult& result, const GroundTruth& truth) {
  auto sequence = scene::LoadSequence(result.scene_file);
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  render::RenderMesh mesh;
  mesh.triangles = sequence->topology.triangles;
  mesh.rest_positions = scene::ToRenderVertices(sequence->topology, sequence->rest_positions);
  mesh.triangle_material.assign(truth.message().triangle_materials().begin(),
                                truth.message().triangle_materials().end());
  render::RendererOptions ro;
  ro.shadow_map_size = static_cast<int>(truth.message().shadow_map_size());
  ro.brdf_model = truth.Model();
  auto renderer = render::PhongRenderer::Create(context, mesh, ro);
  ASSERT_TRUE(renderer.ok()) << renderer.status();
  ASSERT_TRUE((*renderer)->SetMeasuredBrdfs(truth.MeasuredBrdfs()).ok());
  ASSERT_TRUE((*renderer)->SetProceduralMaterials(truth.RendererMaterials()).ok());
  ASSERT_TRUE((*renderer)->SetLights(truth.ActiveLights()).ok());
  auto positions = sequence->LoadFrame(0);
  ASSERT_TRUE(positions.ok());
  render::Pose pose;
  pose.positions = scene::ToRenderVertices(sequence->topology, *positions);
  pose.normals =
      scene::ToRenderVertices(sequence->topology, scene::ComputeFileVertexNormals(sequence->topology, *positions));
  auto image = (*renderer)->Render(pose, truth.Cameras()[0]);
  ASSERT_TRUE(image.ok()) << image.status();
  std::mt19937 rng(1);
  const cv::Mat expected = EncodeSrgb8(image->radiance, {}, rng);
  auto video = scene::VideoSource::Open(sequence->scene.cameras(0), sequence->scene_dir, 0, "camera");
  ASSERT_TRUE(video.ok()) << video.status();
  auto frame = (*video)->ReadFrame(0);
  ASSERT_TRUE(frame.ok()) << frame.status();
  // The reader marks saturated pixels (a channel at the top code value)
  // negative: compared only elsewhere (a highlight >= 1 in light).
  cv::Mat read = frame->clone(), truth8 = expected.clone();
  int saturated = 0;
  for (int y = 0; y < read.rows; ++y) {
    for (int x = 0; x < read.cols; ++x) {
      if (read.at<cv::Vec3f>(y, x)[0] >= 0.0f) continue;
      read.at<cv::Vec3f>(y, x) = cv::Vec3f(0.0f, 0.0f, 0.0f);
      truth8.at<cv::Vec3b>(y, x) = cv::Vec3b(0, 0, 0);
      ++saturated;
    }
  }
  EXPECT_LE(saturated, 2);
  cv::Mat diff;
  cv::absdiff(truth8, EncodeSrgb8(read, {}, rng), diff);
  double max_diff = 0.0;
  cv::minMaxLoc(diff.reshape(1), nullptr, &max_diff);
  EXPECT_EQ(max_diff, 0.0) << saturated << " saturated pixels";
  std::printf("first frame as the truth drawn again: %d saturated pixels\n", saturated);
}

// Issue #15 item 4: --brdf renders another model's truth, records it (the
// model, and GGX's F0 and roughness per material), and the video is exactly
// a render of that truth with that model; it differs from the Phong truth's.
TEST_F(SynthesizerTest, ModelTruthIsRecordedAndRendered) {
  SynthOptions phong_options = SmallOptions("model_phong");
  phong_options.num_frames = 1;
  phong_options.num_cameras = 1;
  SynthOptions o = phong_options;
  o.out_dir = SmallOptions("model_ggx").out_dir;
  o.brdf = brdf::Model::kGgx;
  auto phong = Synthesize(phong_options, *context_);
  ASSERT_TRUE(phong.ok()) << phong.status();
  auto result = Synthesize(o, *context_);
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(phong->truth.brdf(), "phong");
  EXPECT_EQ(result->truth.brdf(), "ggx");
  auto truth = GroundTruth::Load(o.out_dir / "ground_truth" / "truth.json");
  ASSERT_TRUE(truth.ok()) << truth.status();
  EXPECT_EQ(truth->Model(), brdf::Model::kGgx);
  ASSERT_EQ(truth->message().materials_size(), 3);
  const v1::Material& cloth = truth->message().materials(0);
  EXPECT_EQ(cloth.ks_size(), 0);
  ASSERT_EQ(cloth.f0_size(), 3);
  ASSERT_EQ(cloth.roughness_size(), 3);
  EXPECT_NEAR(cloth.f0(0), 0.04, 1e-6);                             // ior 1.5
  EXPECT_NEAR(cloth.roughness(0), std::pow(2.0 / 18.0, 0.25), 1e-6);  // ke 4: Blinn-Phong 16
  EXPECT_NEAR(truth->message().materials(1).f0(0), std::pow(0.4 / 2.4, 2), 1e-6);  // skin, ior 1.4

  ExpectFirstFrameIsTheTruthRendered(*context_, *result, *truth);
  const double from_phong = MeanFrameDifference(o.out_dir, phong_options.out_dir);
  // Measured 0.0004 (a mean over the image, most of it background; as the
  // perturbation tests above compare).
  std::printf("GGX truth vs Phong truth: mean difference %.5f\n", from_phong);
  EXPECT_GT(from_phong, 1e-4);
}

// Issue #15: measured materials (synth --materials) are recorded with their
// networks and gains and drawn from truth.json alone; the analytic slot
// (skin: "-") keeps its parameters.
TEST_F(SynthesizerTest, MeasuredMaterialsAreRecordedAndRendered) {
  const std::filesystem::path merl = std::filesystem::path(MVBRDF_SHARED_DATA_DIR) / "merl_nbrdf/merl_nbrdf.json";
  if (!std::filesystem::exists(merl)) GTEST_SKIP() << "shared test data not found: " << merl;
  SynthOptions o = SmallOptions("measured");
  o.num_frames = 1;
  o.num_cameras = 1;
  o.materials = "cloth=blue-fabric,-,hair=chrome";
  o.merl_file = merl;
  auto result = Synthesize(o, *context_);
  ASSERT_TRUE(result.ok()) << result.status();
  auto truth = GroundTruth::Load(o.out_dir / "ground_truth" / "truth.json");
  ASSERT_TRUE(truth.ok()) << truth.status();
  ASSERT_EQ(truth->message().materials_size(), 3);
  EXPECT_TRUE(truth->IsMeasured(0));
  EXPECT_FALSE(truth->IsMeasured(1));
  EXPECT_TRUE(truth->IsMeasured(2));
  EXPECT_EQ(truth->message().materials(0).measured(), "blue-fabric");
  EXPECT_EQ(truth->message().materials(1).ks_size(), 3);
  EXPECT_EQ(truth->MeasuredBrdfs().size(), 2u);
  EXPECT_GT(truth->message().materials(0).measured_gain(), 1.0);  // a dark fabric is exposed up
  ExpectFirstFrameIsTheTruthRendered(*context_, *result, *truth);

  // Exposed for the highlights into 16-bit frames: a lower gain, written
  // as 16-bit PNGs the scene says are 16-bit, equal to the truth drawn again.
  SynthOptions hdr = SmallOptions("measured16");
  hdr.num_frames = 1;
  hdr.num_cameras = 1;
  hdr.materials = o.materials;
  hdr.merl_file = merl;
  hdr.bit_depth = 16;
  hdr.video_format = VideoFormat::kPng;
  hdr.measured_exposure = SynthOptions::MeasuredExposure::kHighlights;
  auto hdr_result = Synthesize(hdr, *context_);
  ASSERT_TRUE(hdr_result.ok()) << hdr_result.status();
  auto hdr_truth = GroundTruth::Load(hdr.out_dir / "ground_truth" / "truth.json");
  ASSERT_TRUE(hdr_truth.ok()) << hdr_truth.status();
  EXPECT_LT(hdr_truth->message().materials(2).measured_gain(), truth->message().materials(2).measured_gain());
  auto hdr_sequence = scene::LoadSequence(hdr_result->scene_file);
  ASSERT_TRUE(hdr_sequence.ok()) << hdr_sequence.status();
  EXPECT_EQ(hdr_sequence->scene.cameras(0).video().bit_depth(), 16u);
  ExpectFirstFrameIsTheTruthRendered(*context_, *hdr_result, *hdr_truth);
  hdr.lossy_video = true;
  EXPECT_EQ(Synthesize(hdr, *context_).status().code(), absl::StatusCode::kInvalidArgument);

  o.materials = "cloth=no-such-material";
  auto unknown = Synthesize(o, *context_);
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.status().message().find("slot \"cloth\""), std::string::npos) << unknown.status();
}

}  // namespace
}  // namespace mvbrdf::synth
