#include "core/scene/sequence.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "core/base/proto_json.h"
#include "core/scene/scene_test_util.h"

namespace mvbrdf::scene {
namespace {

using testing::FixtureScene;
using testing::TempDir;
using testing::WriteFixture;
using testing::WriteText;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(SequenceTest, FixtureIsValidAndLoads) {
  ASSERT_TRUE(ValidateSceneMessage(FixtureScene()).ok()) << ValidateSceneMessage(FixtureScene());
  TempDir dir;
  const auto file = WriteFixture(dir.path(), FixtureScene());
  auto seq = LoadSequence(file);
  ASSERT_TRUE(seq.ok()) << seq.status();
  EXPECT_EQ(seq->num_frames, testing::kFixtureFrames);
  EXPECT_FALSE(seq->is_static_mesh());
  EXPECT_EQ(seq->topology.triangles.size(), static_cast<size_t>(testing::kFixtureTriangles));
  EXPECT_EQ(seq->topology.num_file_vertices, 5u);
  ASSERT_EQ(seq->cameras.size(), 2u);
  EXPECT_EQ(seq->cameras[1].name, "cam1");
  EXPECT_EQ(seq->cameras[1].width, testing::kFixtureWidth);
  EXPECT_DOUBLE_EQ(seq->cameras[1].distortion[0], 0.01);
  ASSERT_EQ(seq->lights.size(), 3u);
  EXPECT_FALSE(seq->lights[0].directional);
  EXPECT_EQ(seq->lights[0].intensity, glm::vec3(1.0f));  // default
  EXPECT_TRUE(seq->lights[2].directional);
  EXPECT_EQ(seq->lights[2].intensity, glm::vec3(2.0f, 2.0f, 1.8f));
  EXPECT_EQ(seq->FindLight("NW"), 1);
  EXPECT_EQ(seq->FindLight("nope"), -1);

  auto frame3 = seq->LoadFrame(3);
  ASSERT_TRUE(frame3.ok()) << frame3.status();
  for (size_t v = 0; v < frame3->size(); ++v) {
    EXPECT_NEAR((*frame3)[v].x - seq->rest_positions[v].x, 0.3f, 1e-6f);
    EXPECT_EQ((*frame3)[v].y, seq->rest_positions[v].y);
  }
  EXPECT_EQ(seq->LoadFrame(4).status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(seq->LoadFrame(-1).status().code(), absl::StatusCode::kOutOfRange);

  const std::string summary = Summarize(*seq);
  for (const char* expected : {"fixture", "4 from frame 0 at 25 fps", "5 file vertices, 5 render vertices, 6 triangles",
                               "UVs: no", "zero-area triangles: none", "cam1: 32x24, f = (40, 40)", "NE: point at",
                               "sun: directional", "NE,NW: NE, NW", "cloth: sRGB (200, 30, 30)"}) {
    EXPECT_NE(summary.find(expected), std::string::npos) << "missing \"" << expected << "\" in\n" << summary;
  }
}

TEST(SequenceTest, StaticMeshAndFirstFrameOffset) {
  TempDir dir;
  v1::Scene scene = FixtureScene();
  scene.mutable_mesh()->set_path("mesh_0002.obj");  // static: no conversion
  scene.mutable_frames()->set_first(1);
  scene.mutable_frames()->set_count(3);
  scene.mutable_frame_lighting(0)->set_frame(3);
  const auto file = WriteFixture(dir.path(), scene);
  auto seq = LoadSequence(file);
  ASSERT_TRUE(seq.ok()) << seq.status();
  EXPECT_TRUE(seq->is_static_mesh());
  auto frame = seq->LoadFrame(2);
  ASSERT_TRUE(frame.ok());
  EXPECT_EQ(*frame, seq->rest_positions);
  EXPECT_NEAR(seq->rest_positions[0].x, 0.2f, 1e-6f);
}

TEST(SequenceTest, SummaryListsZeroAreaTriangles) {
  TempDir dir;
  v1::Scene scene = FixtureScene();
  scene.mutable_mesh()->set_path("degenerate.obj");
  scene.clear_segmentation_path();
  scene.clear_segment_materials();
  const auto file = WriteFixture(dir.path(), scene);
  WriteText(dir / "degenerate.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n");
  auto seq = LoadSequence(file);
  ASSERT_TRUE(seq.ok()) << seq.status();
  EXPECT_EQ(seq->topology.zero_area_triangles, std::vector<uint32_t>{1});
  EXPECT_NE(Summarize(*seq).find("zero-area triangles: 1 excluded"), std::string::npos) << Summarize(*seq);
}

// One row per error ValidateSceneMessage can report: a mutation of the valid
// fixture, the expected code and a substring that names the field.
struct MessageErrorCase {
  const char* name;
  std::function<void(v1::Scene*)> mutate;
  const char* expected;
};

void SetRotation(v1::Scene* s, int camera, std::vector<double> r) {
  auto* rotation = s->mutable_cameras(camera)->mutable_cam_from_world()->mutable_rotation();
  rotation->Clear();
  for (double v : r) rotation->Add(v);
}

const std::vector<MessageErrorCase>& MessageErrorCases() {
  static const auto* cases = new std::vector<MessageErrorCase>{
      {"MeshPathEmpty", [](v1::Scene* s) { s->mutable_mesh()->clear_path(); }, "scene.mesh.path: required"},
      {"MeshPathBadPattern", [](v1::Scene* s) { s->mutable_mesh()->set_path("mesh_%s.obj"); },
       "scene.mesh.path: expected at most one frame conversion"},
      {"MeshPathTwoConversions", [](v1::Scene* s) { s->mutable_mesh()->set_path("m%d_%d.obj"); }, "scene.mesh.path"},
      {"FrameCountZero", [](v1::Scene* s) { s->mutable_frames()->set_count(0); },
       "scene.frames.count: must be > 0, got 0"},
      {"FramesOverflow", [](v1::Scene* s) { s->mutable_frames()->set_first(4000000000u); }, "scene.frames:"},
      {"FpsZero", [](v1::Scene* s) { s->mutable_frames()->set_fps(0); }, "scene.frames.fps: must be > 0, got 0"},
      {"FpsSubnormal", [](v1::Scene* s) { s->mutable_frames()->set_fps(1e-320); },
       "scene.frames.fps: must be in [1e-06, 1e+06] frames per second"},
      {"FpsNegative", [](v1::Scene* s) { s->mutable_frames()->set_fps(-25); },
       "scene.frames.fps: must be > 0, got -25"},
      {"FpsNan", [](v1::Scene* s) { s->mutable_frames()->set_fps(kNan); },
       "scene.frames.fps: must be a finite number > 0, got nan"},
      {"NoCameras", [](v1::Scene* s) { s->clear_cameras(); }, "scene.cameras: at least one camera"},
      {"CameraNameEmpty", [](v1::Scene* s) { s->mutable_cameras(1)->clear_name(); },
       "scene.cameras[1].name: must not be empty"},
      {"CameraNameDuplicate", [](v1::Scene* s) { s->mutable_cameras(1)->set_name("cam0"); },
       "scene.cameras[1].name: duplicate \"cam0\", also scene.cameras[0].name"},
      {"WidthZero", [](v1::Scene* s) { s->mutable_cameras(1)->set_width(0); },
       "scene.cameras[1].width: must be in 1..65536, got 0"},
      {"HeightZero", [](v1::Scene* s) { s->mutable_cameras(0)->set_height(0); },
       "scene.cameras[0].height: must be in 1..65536, got 0"},
      // 4e9 became a negative int in the camera model ("must be > 0" of render --camera FILE).
      {"WidthHuge", [](v1::Scene* s) { s->mutable_cameras(1)->set_width(4000000000u); },
       "scene.cameras[1].width: must be in 1..65536, got 4000000000"},
      {"FxNegative", [](v1::Scene* s) { s->mutable_cameras(1)->mutable_intrinsics()->set_fx(-1); },
       "scene.cameras[1].intrinsics.fx: must be > 0, got -1"},
      {"FxNan", [](v1::Scene* s) { s->mutable_cameras(1)->mutable_intrinsics()->set_fx(kNan); },
       "scene.cameras[1].intrinsics.fx: must be a finite number > 0, got nan"},
      {"FyZero", [](v1::Scene* s) { s->mutable_cameras(0)->mutable_intrinsics()->set_fy(0); },
       "scene.cameras[0].intrinsics.fy: must be > 0, got 0"},
      {"CxInfinite", [](v1::Scene* s) { s->mutable_cameras(0)->mutable_intrinsics()->set_cx(kInf); },
       "scene.cameras[0].intrinsics.cx: must be a finite number, got inf"},
      {"CyNan", [](v1::Scene* s) { s->mutable_cameras(0)->mutable_intrinsics()->set_cy(kNan); },
       "scene.cameras[0].intrinsics.cy: must be a finite number"},
      {"DistortionSize", [](v1::Scene* s) { s->mutable_cameras(1)->mutable_intrinsics()->add_distortion(0.0); },
       "scene.cameras[1].intrinsics.distortion: expected 0, 4, 5 or 8 values"},
      {"DistortionNan", [](v1::Scene* s) { s->mutable_cameras(1)->mutable_intrinsics()->set_distortion(2, kNan); },
       "scene.cameras[1].intrinsics.distortion[2]: must be a finite number"},
      {"RotationSize",
       [](v1::Scene* s) {
         SetRotation(s, 0, {1, 0, 0, 1});
       },
       "scene.cameras[0].cam_from_world.rotation: expected 9 values (row-major 3x3), got 4"},
      {"RotationNan",
       [](v1::Scene* s) {
         SetRotation(s, 0, {1, 0, 0, 0, 1, 0, 0, 0, kNan});
       },
       "scene.cameras[0].cam_from_world.rotation[8]: must be a finite number"},
      {"RotationNotOrthonormal",
       [](v1::Scene* s) {
         SetRotation(s, 1, {1.1, 0, 0, 0, 1, 0, 0, 0, 1});
       },
       "scene.cameras[1].cam_from_world.rotation: must be orthonormal, but max |R*R^T - I| is 0.21"},
      {"RotationSlightlyOff",
       [](v1::Scene* s) {
         SetRotation(s, 1, {1, 1e-5, 0, 0, 1, 0, 0, 0, 1});
       },
       "scene.cameras[1].cam_from_world.rotation: must be orthonormal"},
      {"RotationReflection",
       [](v1::Scene* s) {
         SetRotation(s, 0, {1, 0, 0, 0, 1, 0, 0, 0, -1});
       },
       "scene.cameras[0].cam_from_world.rotation: determinant must be +1, got -1"},
      {"TranslationSize",
       [](v1::Scene* s) { s->mutable_cameras(0)->mutable_cam_from_world()->mutable_translation()->RemoveLast(); },
       "scene.cameras[0].cam_from_world.translation: expected 3 values"},
      {"TranslationInfinite",
       [](v1::Scene* s) { s->mutable_cameras(0)->mutable_cam_from_world()->set_translation(1, -kInf); },
       "scene.cameras[0].cam_from_world.translation[1]: must be a finite number, got -inf"},
      {"VideoPathEmpty", [](v1::Scene* s) { s->mutable_cameras(1)->mutable_video()->clear_path(); },
       "scene.cameras[1].video.path: required"},
      {"VideoPathBadPattern", [](v1::Scene* s) { s->mutable_cameras(1)->mutable_video()->set_path("c/%f.png"); },
       "scene.cameras[1].video.path: expected at most one frame conversion"},
      // Issue #19 defect 12: a 999999999-digit frame number cost 18 s and 5.9 GB.
      {"MeshPatternTooWide", [](v1::Scene* s) { s->mutable_mesh()->set_path("mesh_%999999999d.obj"); },
       "scene.mesh.path: a frame number is at most 9 digits wide"},
      {"VideoPatternTooWide",
       [](v1::Scene* s) { s->mutable_cameras(1)->mutable_video()->set_path("c/%0999999999d.png"); },
       "scene.cameras[1].video.path: a frame number is at most 9 digits wide"},
      {"VideoEncodingUnknown",
       [](v1::Scene* s) { s->mutable_cameras(1)->mutable_video()->set_encoding(static_cast<v1::ColorEncoding>(7)); },
       "scene.cameras[1].video.encoding: unknown value 7"},
      {"BitDepth12", [](v1::Scene* s) { s->mutable_cameras(0)->mutable_video()->set_bit_depth(12); },
       "scene.cameras[0].video.bit_depth: must be 0, 8 or 16, got 12"},
      // Issue #13: at most kMaxLights (1024) candidate lights.
      {"TooManyLights",
       [](v1::Scene* s) {
         while (s->lights_size() <= kMaxLights) {
           v1::Light* light = s->add_lights();
           *light = s->lights(0);
           light->set_name("extra " + std::to_string(s->lights_size()));
         }
       },
       "scene.lights: at most 1024 lights, got 1025"},
      {"LightNameEmpty", [](v1::Scene* s) { s->mutable_lights(2)->clear_name(); },
       "scene.lights[2].name: must not be empty"},
      {"LightNameDuplicate", [](v1::Scene* s) { s->mutable_lights(2)->set_name("NE"); },
       "scene.lights[2].name: duplicate \"NE\", also scene.lights[0].name"},
      {"LightBothKinds", [](v1::Scene* s) { s->mutable_lights(2)->mutable_position()->Add(1.0); },
       "scene.lights[2]: exactly one of position (point light) and direction (directional light) is required, got "
       "both"},
      {"LightNeitherKind", [](v1::Scene* s) { s->mutable_lights(0)->clear_position(); },
       "scene.lights[0]: exactly one of position"},
      {"LightPositionSize", [](v1::Scene* s) { s->mutable_lights(1)->mutable_position()->RemoveLast(); },
       "scene.lights[1].position: expected 3 values (x, y, z), got 2"},
      {"LightPositionNan", [](v1::Scene* s) { s->mutable_lights(1)->set_position(0, kNan); },
       "scene.lights[1].position[0]: must be a finite number"},
      {"LightDirectionSize", [](v1::Scene* s) { s->mutable_lights(2)->mutable_direction()->Add(0.0); },
       "scene.lights[2].direction: expected 3 values"},
      {"LightDirectionNotUnit", [](v1::Scene* s) { s->mutable_lights(2)->set_direction(1, 1.2); },
       "scene.lights[2].direction: must have unit length (within 0.001, which is renormalised), got length 1.44222"},
      {"LightIntensitySize", [](v1::Scene* s) { s->mutable_lights(2)->mutable_intensity()->RemoveLast(); },
       "scene.lights[2].intensity: expected 3 values"},
      {"LightIntensityNegative", [](v1::Scene* s) { s->mutable_lights(2)->set_intensity(1, -0.5); },
       "scene.lights[2].intensity[1]: must be a finite number in [0, 1e+12]"},
      {"LightIntensityInfinite", [](v1::Scene* s) { s->mutable_lights(2)->set_intensity(0, kInf); },
       "scene.lights[2].intensity[0]: must be a finite number in [0, 1e+12] (linear RGB; 1 is the model's unit light), "
       "got inf"},
      // Issue #19 defect 7: 1e30 overflowed float maths into "mseBrdf": "Infinity".
      {"LightIntensityOverflowsFloatMaths", [](v1::Scene* s) { s->mutable_lights(2)->set_intensity(2, 1e30); },
       "scene.lights[2].intensity[2]: must be a finite number in [0, 1e+12]"},
      {"LightPositionFarAway", [](v1::Scene* s) { s->mutable_lights(1)->set_position(1, -1e30); },
       "scene.lights[1].position[1]: must be within +-1e+09"},
      // Issue #19: validate said "valid" for scenes that run then rejected.
      {"NoLights",
       [](v1::Scene* s) {
         s->clear_lights();
         s->clear_light_configurations();
         s->clear_frame_lighting();
       },
       "scene.lights: at least one light is required"},
      {"EveryIntensityZero",
       [](v1::Scene* s) {
         for (auto& light : *s->mutable_lights()) {
           light.clear_intensity();
           for (int c = 0; c < 3; ++c) light.add_intensity(0.0);
         }
       },
       "scene.lights: every light's intensity is 0"},
      {"FpsInfinite", [](v1::Scene* s) { s->mutable_frames()->set_fps(kInf); },
       "scene.frames.fps: must be a finite number > 0, got inf"},
      {"FocalLengthInfinite", [](v1::Scene* s) { s->mutable_cameras(0)->mutable_intrinsics()->set_fx(kInf); },
       "scene.cameras[0].intrinsics.fx: must be a finite number > 0, got inf"},
      {"ConfigurationNameEmpty", [](v1::Scene* s) { s->mutable_light_configurations(1)->clear_name(); },
       "scene.light_configurations[1].name: must not be empty"},
      {"ConfigurationNameDuplicate", [](v1::Scene* s) { s->mutable_light_configurations(1)->set_name("NE,NW"); },
       "scene.light_configurations[1].name: duplicate \"NE,NW\", also scene.light_configurations[0].name"},
      {"ConfigurationNoLights", [](v1::Scene* s) { s->mutable_light_configurations(1)->clear_lights(); },
       "scene.light_configurations[1].lights: at least one light"},
      {"ConfigurationUnknownLight", [](v1::Scene* s) { s->mutable_light_configurations(0)->add_lights("SE"); },
       "scene.light_configurations[0].lights[2]: unknown light \"SE\" in configuration \"NE,NW\" (the scene has "
       "\"NE\", \"NW\", \"sun\")"},
      {"FrameOffsetBeforeStart",
       [](v1::Scene* s) {
         s->mutable_frames()->set_first(2);
         s->mutable_cameras(1)->mutable_video()->set_frame_offset(-3);
       },
       "scene.cameras[1].video.frame_offset: camera \"cam1\": frame 2 of the sequence would be frame -1 of its video, "
       "before the video's start (frame_offset -3)"},
      {"FrameOffsetPastInt32",
       [](v1::Scene* s) { s->mutable_cameras(0)->mutable_video()->set_frame_offset(INT32_MAX); },
       "scene.cameras[0].video.frame_offset: camera \"cam0\": frame 3 of the sequence would be frame 2147483650"},
      {"ConfigurationDuplicateLight", [](v1::Scene* s) { s->mutable_light_configurations(0)->add_lights("NE"); },
       "scene.light_configurations[0].lights[2]: duplicate light \"NE\", also "
       "scene.light_configurations[0].lights[0]"},
      {"FrameLightingBeforeFirst",
       [](v1::Scene* s) {
         s->mutable_frames()->set_first(2);
         s->mutable_frame_lighting(0)->set_frame(1);
       },
       "scene.frame_lighting[0].frame: must be in [2, 6)"},
      {"FrameLightingPastEnd", [](v1::Scene* s) { s->mutable_frame_lighting(0)->set_frame(4); },
       "scene.frame_lighting[0].frame: must be in [0, 4) (scene.frames: first, first + count), got 4"},
      {"FrameLightingDuplicateFrame",
       [](v1::Scene* s) {
         auto* fl = s->add_frame_lighting();
         fl->set_frame(1);
         fl->add_lights("NW");
       },
       "scene.frame_lighting[1].frame: duplicate frame 1, also scene.frame_lighting[0].frame"},
      {"FrameLightingUnknownLight", [](v1::Scene* s) { s->mutable_frame_lighting(0)->add_lights("moon"); },
       "scene.frame_lighting[0].lights[1]: unknown light \"moon\" in frame 1"},
      {"FrameLightingDuplicateLight", [](v1::Scene* s) { s->mutable_frame_lighting(0)->add_lights("NE"); },
       "scene.frame_lighting[0].lights[1]: duplicate light \"NE\""},
      {"SeedNameEmpty", [](v1::Scene* s) { s->mutable_material_seeds(0)->clear_name(); },
       "scene.material_seeds[0].name: must not be empty"},
      {"SeedNameDuplicate", [](v1::Scene* s) { s->mutable_material_seeds(1)->set_name("cloth"); },
       "scene.material_seeds[1].name: duplicate \"cloth\", also scene.material_seeds[0].name"},
      {"SeedColourSize", [](v1::Scene* s) { s->mutable_material_seeds(1)->mutable_srgb8()->RemoveLast(); },
       "scene.material_seeds[1].srgb8: expected 3 values (8-bit sRGB R, G, B (or linear_rgb)), got 2"},
      {"SeedColourTooLarge", [](v1::Scene* s) { s->mutable_material_seeds(1)->set_srgb8(2, 256); },
       "scene.material_seeds[1].srgb8[2]: must be <= 255, got 256"},
      {"SegmentNameEmpty", [](v1::Scene* s) { s->mutable_segment_materials(0)->clear_segment(); },
       "scene.segment_materials[0].segment: must not be empty"},
      {"SegmentNameDuplicate", [](v1::Scene* s) { s->add_segment_materials()->CopyFrom(s->segment_materials(0)); },
       "scene.segment_materials[1].segment: duplicate \"body\", also scene.segment_materials[0].segment"},
      {"SegmentNoMaterials", [](v1::Scene* s) { s->mutable_segment_materials(0)->clear_materials(); },
       "scene.segment_materials[0].materials: at least one material seed"},
      {"SegmentUnknownSeed", [](v1::Scene* s) { s->mutable_segment_materials(0)->add_materials("hair"); },
       "scene.segment_materials[0].materials[2]: unknown material seed \"hair\" in segment \"body\""},
      {"SegmentDuplicateSeed", [](v1::Scene* s) { s->mutable_segment_materials(0)->add_materials("skin"); },
       "scene.segment_materials[0].materials[2]: duplicate material seed \"skin\""},
      {"SegmentsWithoutSegmentation", [](v1::Scene* s) { s->clear_segmentation_path(); },
       "scene.segment_materials: given, but scene.segmentation_path is empty"},
      // Paths stay inside the scene's directory (a bundle on the server).
      {"MeshPathDotDot", [](v1::Scene* s) { s->mutable_mesh()->set_path("../x_%04d.obj"); },
       "scene.mesh.path: must be a relative path inside the scene's directory (no \"..\" component), got "
       "\"../x_%04d.obj\""},
      {"MeshPathDotDotInside", [](v1::Scene* s) { s->mutable_mesh()->set_path("m/../../x.obj"); },
       "scene.mesh.path: must be a relative path inside"},
      {"MeshPathAbsolute", [](v1::Scene* s) { s->mutable_mesh()->set_path("/etc/passwd"); },
       "scene.mesh.path: must be a relative path inside the scene's directory (not absolute), got \"/etc/passwd\""},
      {"VideoPathAbsolute", [](v1::Scene* s) { s->mutable_cameras(1)->mutable_video()->set_path("/dev/zero"); },
       "scene.cameras[1].video.path: must be a relative path inside"},
      {"VideoPathBackslash", [](v1::Scene* s) { s->mutable_cameras(0)->mutable_video()->set_path("..\\c.mkv"); },
       "scene.cameras[0].video.path: must be a relative path inside"},
      {"SegmentationPathDotDot", [](v1::Scene* s) { s->set_segmentation_path("../segments.txt"); },
       "scene.segmentation_path: must be a relative path inside"},
  };
  return *cases;
}

class MessageErrorTest : public ::testing::TestWithParam<MessageErrorCase> {};

TEST_P(MessageErrorTest, ReportsTheField) {
  v1::Scene scene = FixtureScene();
  GetParam().mutate(&scene);
  const absl::Status status = ValidateSceneMessage(scene);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << status;
  EXPECT_NE(status.message().find(GetParam().expected), std::string::npos)
      << "expected \"" << GetParam().expected << "\" in: " << status.message();
}

INSTANTIATE_TEST_SUITE_P(AllErrors, MessageErrorTest, ::testing::ValuesIn(MessageErrorCases()),
                         [](const ::testing::TestParamInfo<MessageErrorCase>& info) { return info.param.name; });

// Errors found by LoadSequence: each row writes the fixture, breaks it on disk
// (or in the message), and expects a code and a substring.
struct FileErrorCase {
  const char* name;
  std::function<void(v1::Scene*)> mutate_scene;
  std::function<void(const std::filesystem::path& dir)> break_files;
  absl::StatusCode code;
  const char* expected;
};

const std::vector<FileErrorCase>& FileErrorCases() {
  static const auto* cases = new std::vector<FileErrorCase>{
      {"MissingMeshFile", [](v1::Scene* s) { s->mutable_mesh()->set_path("body_%04d.obj"); }, nullptr,
       absl::StatusCode::kNotFound, "scene.mesh.path (frame 0): mesh file not found: "},
      {"MissingLaterMeshFile", nullptr,
       [](const std::filesystem::path& dir) { std::filesystem::remove(dir / "mesh_0002.obj"); },
       absl::StatusCode::kNotFound, "scene.mesh.path (frame 2): mesh file not found"},
      {"TopologyDiffersBetweenFrames", nullptr,
       [](const std::filesystem::path& dir) {
         std::string obj = testing::PyramidObj(2);
         obj.replace(obj.find("f 2 5 3"), 7, "f 2 5 4");
         WriteText(dir / "mesh_0002.obj", obj);
       },
       absl::StatusCode::kInvalidArgument, "topology differs from frame 0"},
      {"NanVertexInLaterFrame", nullptr,
       [](const std::filesystem::path& dir) {
         WriteText(dir / "mesh_0001.obj", "v 0 0 nan\n" + testing::PyramidObj(1));
       },
       absl::StatusCode::kInvalidArgument, "scene.mesh.path (frame 1)"},
      {"MissingVideo", [](v1::Scene* s) { s->mutable_cameras(1)->mutable_video()->set_path("cam1.mkv"); }, nullptr,
       absl::StatusCode::kNotFound, "scene.cameras[1].video.path: video file not found"},
      {"MissingImageSequence", [](v1::Scene* s) { s->mutable_cameras(1)->mutable_video()->set_path("x/%04d.png"); },
       nullptr, absl::StatusCode::kNotFound, "scene.cameras[1].video.path: first frame not found"},
      {"WrongImageSize", [](v1::Scene* s) { s->mutable_cameras(1)->set_width(64); }, nullptr,
       absl::StatusCode::kInvalidArgument, "scene.cameras[1].video: frames are 32x24, expected 64x24"},
      {"FrameOffsetPastTheVideosEnd", [](v1::Scene* s) { s->mutable_cameras(0)->mutable_video()->set_frame_offset(1); },
       nullptr, absl::StatusCode::kInvalidArgument,
       "scene.cameras[0].video: has 3 frames from frame 1, the scene needs 4; camera \"cam0\": frame 3 of the sequence "
       "is frame 4 of its video, past the video's end (frame_offset 1)"},
      {"TooFewFrames", nullptr,
       [](const std::filesystem::path& dir) { std::filesystem::remove(dir / "cam0/0003.png"); },
       absl::StatusCode::kInvalidArgument, "scene.cameras[0].video: has 3 frames from frame 0, the scene needs 4"},
      {"WrongBitDepth", [](v1::Scene* s) { s->mutable_cameras(0)->mutable_video()->set_bit_depth(16); }, nullptr,
       absl::StatusCode::kInvalidArgument, "scene.cameras[0].video: frame 0"},
      {"UnknownLightInConfiguration", [](v1::Scene* s) { s->mutable_light_configurations(1)->set_lights(0, "moon"); },
       nullptr, absl::StatusCode::kInvalidArgument,
       "scene.light_configurations[1].lights[0]: unknown light \"moon\" in configuration \"sun\""},
      {"DuplicateCameraNames", [](v1::Scene* s) { s->mutable_cameras(0)->set_name("cam1"); }, nullptr,
       absl::StatusCode::kInvalidArgument, "scene.cameras[1].name: duplicate \"cam1\", also scene.cameras[0].name"},
      {"NonPositiveFocalLength", [](v1::Scene* s) { s->mutable_cameras(0)->mutable_intrinsics()->set_fy(-40); },
       nullptr, absl::StatusCode::kInvalidArgument, "scene.cameras[0].intrinsics.fy: must be > 0, got -40"},
      {"SegmentationLineCount", nullptr,
       [](const std::filesystem::path& dir) { WriteText(dir / "segments.txt", "base\nbody\n"); },
       absl::StatusCode::kInvalidArgument, "scene.segmentation_path: "},
      {"SegmentationMissesSegment", nullptr,
       [](const std::filesystem::path& dir) { WriteText(dir / "segments.txt", "a\na\nb\nb\nb\nb\n"); },
       absl::StatusCode::kInvalidArgument, "scene.segment_materials[0].segment: segment \"body\" does not occur"},
      {"SegmentationMissing", [](v1::Scene* s) { s->set_segmentation_path("nope.txt"); }, nullptr,
       absl::StatusCode::kNotFound, "scene.segmentation_path: file not found"},
      {"UnknownJsonField", nullptr,
       [](const std::filesystem::path& dir) { WriteText(dir / "scene.json", "{\"cameraz\": []}"); },
       absl::StatusCode::kInvalidArgument, "scene.json"},
      // Turned around (a half turn about its y axis): the pyramid is behind cam0.
      {"CameraSeesNothingBehind",
       [](v1::Scene* s) {
         auto* pose = s->mutable_cameras(0)->mutable_cam_from_world();
         for (int k : {0, 1, 2, 6, 7, 8}) pose->set_rotation(k, -pose->rotation(k));
         pose->set_translation(0, -pose->translation(0));
         pose->set_translation(2, -pose->translation(2));
       },
       nullptr, absl::StatusCode::kInvalidArgument,
       "scene.cameras[0]: sees none of the mesh in frame 0: all 5 vertices lie behind the camera"},
      // Principal point far to the right: the pyramid is left of the image.
      {"CameraSeesNothingBeside", [](v1::Scene* s) { s->mutable_cameras(0)->mutable_intrinsics()->set_cx(500); },
       nullptr, absl::StatusCode::kInvalidArgument,
       "scene.cameras[0]: sees none of the mesh in frame 0: all 5 vertices lie"},
      {"MissingSceneFile", nullptr,
       [](const std::filesystem::path& dir) { std::filesystem::remove(dir / "scene.json"); },
       absl::StatusCode::kNotFound, "scene.json"},
  };
  return *cases;
}

class FileErrorTest : public ::testing::TestWithParam<FileErrorCase> {};

TEST_P(FileErrorTest, ReportsTheFieldOrFile) {
  TempDir dir;
  v1::Scene scene = FixtureScene();
  if (GetParam().mutate_scene) GetParam().mutate_scene(&scene);
  const auto file = WriteFixture(dir.path(), scene);
  if (GetParam().break_files) GetParam().break_files(dir.path());
  auto seq = LoadSequence(file);
  EXPECT_EQ(seq.status().code(), GetParam().code) << seq.status();
  EXPECT_NE(seq.status().message().find(GetParam().expected), std::string::npos)
      << "expected \"" << GetParam().expected << "\" in: " << seq.status().message();
}

INSTANTIATE_TEST_SUITE_P(AllErrors, FileErrorTest, ::testing::ValuesIn(FileErrorCases()),
                         [](const ::testing::TestParamInfo<FileErrorCase>& info) { return info.param.name; });

TEST(SequenceTest, OptionsSkipFramesAndVideos) {
  TempDir dir;
  const auto file = WriteFixture(dir.path(), FixtureScene());
  std::filesystem::remove(dir / "cam0/0003.png");
  WriteText(dir / "mesh_0003.obj", "v 0 0 nan\n" + testing::PyramidObj(3));
  LoadOptions options;
  options.check_all_frames = false;
  options.probe_videos = false;
  auto seq = LoadSequence(file, options);
  ASSERT_TRUE(seq.ok()) << seq.status();
  EXPECT_EQ(seq->LoadFrame(3).status().code(), absl::StatusCode::kInvalidArgument);
}

// Without check_all_frames, every frame's mesh file must still exist (a stat
// each): the server then rejects a bundle without one at submit.
TEST(SequenceTest, MissingLaterMeshFileIsFoundWithoutReadingFrames) {
  TempDir dir;
  const auto file = WriteFixture(dir.path(), FixtureScene());
  std::filesystem::remove(dir / "mesh_0002.obj");
  LoadOptions options;
  options.check_all_frames = false;
  auto seq = LoadSequence(file, options);
  EXPECT_EQ(seq.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(seq.status().message().find("scene.mesh.path (frame 2): mesh file not found: "), std::string::npos)
      << seq.status();
  EXPECT_NE(seq.status().message().find("mesh_0002.obj"), std::string::npos) << seq.status();
}

// A frame is imported once: later reads, also through a copy of the
// sequence, come from its FrameCache (here after the file is gone).
TEST(SequenceTest, AFrameReadOnceComesFromTheCacheAfterwards) {
  TempDir dir;
  const auto file = WriteFixture(dir.path(), FixtureScene());
  LoadOptions options;
  options.check_all_frames = false;
  auto seq = LoadSequence(file, options);
  ASSERT_TRUE(seq.ok()) << seq.status();
  auto first = seq->LoadFrame(3);
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_EQ(seq->frame_cache->size(), 1u);
  std::filesystem::remove(dir / "mesh_0003.obj");
  const Sequence copy = *seq;
  auto again = copy.LoadFrame(3);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(*again, *first);
  // A frame not read before still goes to its file.
  std::filesystem::remove(dir / "mesh_0002.obj");
  EXPECT_EQ(copy.LoadFrame(2).status().code(), absl::StatusCode::kNotFound);
}

// Errors are one line and name files as the scene does, relative to its
// directory (on the server that directory is private).
TEST(SequenceTest, ErrorsAreOneLineAndNameFilesRelativeToTheScene) {
  TempDir dir;
  const auto file = WriteFixture(dir.path(), FixtureScene());
  WriteText(dir / "mesh_0002.obj", "v 0 0 nan\n" + testing::PyramidObj(2));
  auto nan = LoadSequence(file);
  EXPECT_NE(nan.status().message().find("scene.mesh.path (frame 2): mesh_0002.obj: "), std::string::npos)
      << nan.status();
  EXPECT_EQ(nan.status().message().find(dir.path().string()), std::string::npos) << nan.status();

  WriteText(dir / "scene.json", "{\n  \"name\": \"x\",\n  \"frames\",, {\n    \"count\": 3\n  }\n}\n");
  auto malformed = LoadSequence(file);
  EXPECT_EQ(malformed.status().code(), absl::StatusCode::kInvalidArgument);
  const std::string message(malformed.status().message());
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  EXPECT_EQ(message.rfind("scene.json: not a valid mvbrdf.v1.Scene JSON document: ", 0), 0u) << message;
  EXPECT_NE(message.find(" near \""), std::string::npos) << message;
}

// A close-up whose image lies inside one big triangle sees no vertex, but
// sees the mesh: it must pass.
TEST(SequenceTest, CloseUpOfACoarseMeshPasses) {
  TempDir dir;
  v1::Scene scene = FixtureScene();
  scene.mutable_mesh()->set_path("quad.obj");
  scene.clear_segmentation_path();
  scene.clear_segment_materials();
  for (int i = 0; i < 2; ++i) {
    scene.mutable_cameras(i)->mutable_intrinsics()->set_fx(4000);
    scene.mutable_cameras(i)->mutable_intrinsics()->set_fy(4000);
  }
  const auto file = WriteFixture(dir.path(), scene);
  // A big square in the plane z = 0 facing cam0, and a wall x = 0 facing cam1
  // (which looks along -x from x = 3), each far larger than the view.
  WriteText(dir / "quad.obj",
            "v -50 -50 0\nv 50 -50 0\nv 50 50 0\nv -50 50 0\nv 0 -50 -50\nv 0 50 -50\nv 0 50 50\nv 0 -50 50\n"
            "f 1 2 3\nf 1 3 4\nf 5 6 7\nf 5 7 8\n");
  auto seq = LoadSequence(file);
  EXPECT_TRUE(seq.ok()) << seq.status();
}

// Issue #13: an orthographic camera's frustum is a box along its axis
// (normalised coordinates x, y, not x/z, y/z): it loads when it sees the
// mesh, and one moved sideways off it is refused as a pinhole would be.
TEST(SequenceTest, OrthographicCameraLoadsAndOneBesideTheMeshIsRefused) {
  TempDir dir;
  v1::Scene scene = FixtureScene();
  v1::Camera* cam = scene.mutable_cameras(0);
  cam->set_model(v1::ORTHOGRAPHIC);
  cam->set_pixel_size(0.05);  // 32 x 24 pixels: 1.6 x 1.2 world units
  cam->mutable_intrinsics()->clear_fx();
  cam->mutable_intrinsics()->clear_fy();
  auto seq = LoadSequence(WriteFixture(dir.path(), scene));
  ASSERT_TRUE(seq.ok()) << seq.status();
  EXPECT_TRUE(seq->cameras[0].orthographic());
  EXPECT_EQ(seq->cameras[0].pixel_size, 0.05);
  EXPECT_NE(Summarize(*seq).find("cam0: 32x24, orthographic, pixel size 0.05"), std::string::npos) << Summarize(*seq);

  TempDir beside;
  cam->mutable_cam_from_world()->set_translation(0, 4.5);  // the mesh 4 to 5.5 units right of the axis
  auto refused = LoadSequence(WriteFixture(beside.path(), scene));
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("scene.cameras[0]: sees none of the mesh in frame 0"), std::string::npos)
      << refused.status();
  EXPECT_NE(refused.status().message().find("right of its image"), std::string::npos) << refused.status();
  // A telecentric calibration cannot tell the depth origin: the message says where to put it.
  TempDir behind;
  cam->mutable_cam_from_world()->set_translation(0, -0.5);
  cam->mutable_cam_from_world()->set_translation(2, -10.0);
  refused = LoadSequence(WriteFixture(behind.path(), scene));
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("behind the camera (check cam_from_world: world to camera, OpenCV axes "
                                            "with z forward; an orthographic camera sees only z_cam > 0"),
            std::string::npos)
      << refused.status();
}

}  // namespace
}  // namespace mvbrdf::scene
