#include "core/scene/scene_test_util.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/files.h"
#include "core/base/proto_json.h"

namespace mvbrdf::scene::testing {

TempDir::TempDir() {
  std::string tmpl = (std::filesystem::temp_directory_path() / "mvbrdf_scene_test_XXXXXX").string();
  if (mkdtemp(tmpl.data()) == nullptr) ADD_FAILURE() << "mkdtemp failed for " << tmpl;
  path_ = tmpl;
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

void WriteText(const std::filesystem::path& file, const std::string& text) {
  const absl::Status status = WriteStringToFile(file, text);
  ASSERT_TRUE(status.ok()) << status;
}

std::string PyramidObj(int frame) {
  const double dx = 0.1 * frame;
  std::string obj = "# square pyramid, apex up\n";
  const double v[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}, {0.5, 1, 0.5}};
  for (const auto& p : v) absl::StrAppendFormat(&obj, "v %.9g %.9g %.9g\n", p[0] + dx, p[1], p[2]);
  // Base (two triangles, facing -y) and four sides.
  obj += "f 1 2 3\nf 1 3 4\nf 1 5 2\nf 2 5 3\nf 3 5 4\nf 4 5 1\n";
  return obj;
}

v1::Scene FixtureScene() {
  v1::Scene s;
  s.set_name("fixture");
  s.mutable_mesh()->set_path("mesh_%04d.obj");
  s.mutable_frames()->set_first(0);
  s.mutable_frames()->set_count(kFixtureFrames);
  s.mutable_frames()->set_fps(25);
  for (int i = 0; i < 2; ++i) {
    v1::Camera* c = s.add_cameras();
    c->set_name(absl::StrCat("cam", i));
    c->set_width(kFixtureWidth);
    c->set_height(kFixtureHeight);
    c->mutable_intrinsics()->set_fx(40);
    c->mutable_intrinsics()->set_fy(40);
    c->mutable_intrinsics()->set_cx(15.5);
    c->mutable_intrinsics()->set_cy(11.5);
    if (i == 1) {
      for (double d : {0.01, -0.002, 0.0, 0.0, 0.0}) c->mutable_intrinsics()->add_distortion(d);
    }
    // cam0 looks along +z; cam1 along -x (a rotation about y by -90 degrees).
    const double r0[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    const double r1[9] = {0, 0, -1, 0, 1, 0, 1, 0, 0};
    for (double r : (i == 0 ? r0 : r1)) c->mutable_cam_from_world()->add_rotation(r);
    for (double t : {-0.5, -0.5, 3.0}) c->mutable_cam_from_world()->add_translation(t);
    c->mutable_video()->set_path(absl::StrCat("cam", i, "/%04d.png"));
    c->mutable_video()->set_encoding(v1::SRGB);
  }
  auto add_point = [&](const char* name, double x, double y, double z) {
    v1::Light* l = s.add_lights();
    l->set_name(name);
    for (double p : {x, y, z}) l->add_position(p);
  };
  add_point("NE", 2, 3, 2);
  add_point("NW", -2, 3, 2);
  v1::Light* sun = s.add_lights();
  sun->set_name("sun");
  for (double d : {0.0, 0.6, 0.8}) sun->add_direction(d);
  for (double c : {2.0, 2.0, 1.8}) sun->add_intensity(c);
  v1::LightConfiguration* both = s.add_light_configurations();
  both->set_name("NE,NW");
  both->add_lights("NE");
  both->add_lights("NW");
  v1::LightConfiguration* sun_only = s.add_light_configurations();
  sun_only->set_name("sun");
  sun_only->add_lights("sun");
  v1::FrameLighting* fl = s.add_frame_lighting();
  fl->set_frame(1);
  fl->add_lights("NE");
  v1::MaterialSeed* cloth = s.add_material_seeds();
  cloth->set_name("cloth");
  for (uint32_t c : {200u, 30u, 30u}) cloth->add_srgb8(c);
  v1::MaterialSeed* skin = s.add_material_seeds();
  skin->set_name("skin");
  for (uint32_t c : {230u, 180u, 150u}) skin->add_srgb8(c);
  s.set_segmentation_path("segments.txt");
  v1::SegmentMaterials* body = s.add_segment_materials();
  body->set_segment("body");
  body->add_materials("cloth");
  body->add_materials("skin");
  return s;
}

std::filesystem::path WriteFixture(const std::filesystem::path& dir, const v1::Scene& scene) {
  for (int t = 0; t < kFixtureFrames; ++t) {
    WriteText(dir / absl::StrFormat("mesh_%04d.obj", t), PyramidObj(t));
  }
  WriteText(dir / "segments.txt", "base\nbase\nbody\nbody\nbody\nbody\n");
  for (int c = 0; c < 2; ++c) {
    std::filesystem::create_directories(dir / absl::StrCat("cam", c));
    for (int t = 0; t < kFixtureFrames; ++t) {
      cv::Mat image(kFixtureHeight, kFixtureWidth, CV_8UC3, cv::Scalar(10 * t, 50 + c, 100));
      const std::string file = (dir / absl::StrFormat("cam%d/%04d.png", c, t)).string();
      EXPECT_TRUE(cv::imwrite(file, image)) << file;
    }
  }
  const std::filesystem::path file = dir / "scene.json";
  const absl::Status status = WriteJsonFile(file, scene);
  EXPECT_TRUE(status.ok()) << status;
  return file;
}

}  // namespace mvbrdf::scene::testing
