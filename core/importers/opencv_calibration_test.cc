#include "core/importers/opencv_calibration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

namespace mvbrdf::importers {
namespace {

std::filesystem::path Write(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path) << text;
  return path;
}
std::filesystem::path Temp(const std::string& name) { return std::filesystem::path(testing::TempDir()) / name; }

// OpenCV's calibration sample's keys, with a pose as rvec (90 degrees about
// z) and tvec.
constexpr char kYaml[] =
    "%YAML:1.0\n"
    "---\n"
    "image_width: 160\n"
    "image_height: 120\n"
    "camera_matrix: !!opencv-matrix\n"
    "   rows: 3\n"
    "   cols: 3\n"
    "   dt: d\n"
    "   data: [ 200., 0., 79.5, 0., 210., 59.25, 0., 0., 1. ]\n"
    "distortion_coefficients: !!opencv-matrix\n"
    "   rows: 5\n"
    "   cols: 1\n"
    "   dt: d\n"
    "   data: [ 0.1, -0.2, 0.001, -0.002, 0.03 ]\n"
    "rvec: [ 0., 0., 1.5707963267948966 ]\n"
    "tvec: [ 1., 2., 3. ]\n";

TEST(OpenCvCalibration, SampleLayoutAndRodrigues) {
  auto cameras = ReadOpenCvCalibration(Write(Temp("ocv/cam7.yml"), kYaml));
  ASSERT_TRUE(cameras.ok()) << cameras.status();
  ASSERT_EQ(cameras->size(), 1u);
  const v1::Camera& c = (*cameras)[0];
  EXPECT_EQ(c.name(), "cam7");
  EXPECT_EQ(c.width(), 160u);
  EXPECT_EQ(c.height(), 120u);
  // OpenCV's pixel convention is mvbrdf's: no shift.
  EXPECT_EQ(c.intrinsics().cx(), 79.5);
  EXPECT_EQ(c.intrinsics().cy(), 59.25);
  EXPECT_EQ(c.intrinsics().fy(), 210);
  ASSERT_EQ(c.intrinsics().distortion_size(), 5);
  EXPECT_EQ(c.intrinsics().distortion(2), 0.001);  // p1 stays p1
  EXPECT_EQ(c.intrinsics().distortion(3), -0.002);
  // Rodrigues (0, 0, pi/2): x -> y, R = [0 -1 0; 1 0 0; 0 0 1] (world to camera).
  const double expected[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(c.cam_from_world().rotation(i), expected[i], 1e-15) << i;
  EXPECT_EQ(c.cam_from_world().translation(2), 3);
}

TEST(OpenCvCalibration, JsonCamerasSequenceAndCameraToWorld) {
  const std::string json = R"({
  "cameras": [
    {"name": "left", "width": 64, "height": 48, "K": [[50, 0, 31.5], [0, 50, 23.5], [0, 0, 1]],
     "R": [1, 0, 0, 0, 1, 0, 0, 0, 1], "T": [0, 0, 5]},
    {"name": "right", "imageSize": [64, 48],
     "cameraMatrix": {"type_id": "opencv-matrix", "rows": 3, "cols": 3, "dt": "d",
                      "data": [50, 0, 31.5, 0, 50, 23.5, 0, 0, 1]},
     "extrinsics_convention": "camera_to_world",
     "R": [0, -1, 0, 1, 0, 0, 0, 0, 1], "T": [1, 2, 3], "D": [0, 0, 0, 0, 0, 0, 0, 0]}
  ]
})";
  auto cameras = ReadOpenCvCalibration(Write(Temp("ocv_json/rig.json"), json));
  ASSERT_TRUE(cameras.ok()) << cameras.status();
  ASSERT_EQ(cameras->size(), 2u);
  EXPECT_EQ((*cameras)[0].name(), "left");
  EXPECT_EQ((*cameras)[0].cam_from_world().translation(2), 5);
  const v1::Camera& right = (*cameras)[1];
  EXPECT_EQ(right.width(), 64u);
  EXPECT_EQ(right.intrinsics().distortion_size(), 0);  // trailing zeros: no distortion
  // camera_to_world inverted: R^T, -R^T T. R^T = [0 1 0; -1 0 0; 0 0 1].
  const double r[9] = {0, 1, 0, -1, 0, 0, 0, 0, 1}, t[3] = {-2, 1, -3};
  for (int i = 0; i < 9; ++i) EXPECT_EQ(right.cam_from_world().rotation(i), r[i]) << i;
  for (int i = 0; i < 3; ++i) EXPECT_EQ(right.cam_from_world().translation(i), t[i]) << i;
}

TEST(OpenCvCalibration, DirectoryInNameOrderAndXml) {
  const std::filesystem::path dir = Temp("ocv_dir");
  Write(dir / "b.yaml", kYaml);
  Write(dir / "a.xml",
        "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_width>160</image_width><image_height>120</image_height>\n"
        "<camera_matrix type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols><dt>d</dt>\n"
        "<data>200. 0. 79.5 0. 210. 59.25 0. 0. 1.</data></camera_matrix>\n"
        "<R type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols><dt>d</dt><data>1 0 0 0 1 0 0 0 1</data></R>\n"
        "<T type_id=\"opencv-matrix\"><rows>3</rows><cols>1</cols><dt>d</dt><data>0 0 4</data></T>\n"
        "</opencv_storage>\n");
  Write(dir / "notes.txt", "not a calibration");
  auto cameras = ReadOpenCvCalibration(dir);
  ASSERT_TRUE(cameras.ok()) << cameras.status();
  ASSERT_EQ(cameras->size(), 2u);
  EXPECT_EQ((*cameras)[0].name(), "a");
  EXPECT_EQ((*cameras)[0].cam_from_world().translation(2), 4);
  EXPECT_EQ((*cameras)[1].name(), "b");
}

TEST(OpenCvCalibration, BadInputsNameFileAndKey) {
  struct Case {
    std::string text, expected;
  };
  const std::string pose = "R: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nT: [0, 0, 1]\n";
  const std::string size = "image_width: 4\nimage_height: 3\n";
  for (const Case& c : std::vector<Case>{
           {"%YAML:1.0\n" + size + pose, "bad.yml: camera_matrix: missing"},
           {"%YAML:1.0\n" + size + "K: [1, 0, 0, 0, 1, 0]\n" + pose, "bad.yml: K: must be 3x3, got 1x6"},
           {"%YAML:1.0\n" + size +
                "K: !!opencv-matrix\n  rows: 1\n  cols: 9\n  dt: d\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n" + pose,
            "bad.yml: K: must be 3x3, got 1x9"},
           {"%YAML:1.0\n" + size + "K: [1, 0.5, 0, 0, 1, 0, 0, 0, 1]\n" + pose, "bad.yml: K: has skew"},
           {"%YAML:1.0\nimage_height: 3\nK: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n" + pose, "bad.yml: image_width: missing"},
           {"%YAML:1.0\n" + size + "K: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nT: [0, 0, 1]\n", "bad.yml: R: missing"},
           {"%YAML:1.0\n" + size + "K: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nrvec: [0, 0, 0]\n" + pose,
            "bad.yml: R: given together with rvec"},
           {"%YAML:1.0\n" + size + "K: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nD: [0.1, 0.2, 0, 0, 0, 0.3]\n" + pose,
            "bad.yml: D: has 6 coefficients"},
           {"%YAML:1.0\n" + size + "K: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nextrinsics_convention: c2w\n" + pose,
            "bad.yml: extrinsics_convention: must be"},
           {"%YAML:1.0\ncameras:\n  - {width: 4}\n", "bad.yml: cameras[0].name: missing"},
       }) {
    auto cameras = ReadOpenCvCalibration(Write(Temp("ocv_bad/bad.yml"), c.text));
    ASSERT_FALSE(cameras.ok()) << c.expected;
    EXPECT_EQ(cameras.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(std::string(cameras.status().message()).find(c.expected), std::string::npos) << cameras.status();
  }
  EXPECT_EQ(ReadOpenCvCalibration("/nonexistent/cams").status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace mvbrdf::importers
