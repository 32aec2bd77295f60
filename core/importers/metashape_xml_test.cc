#include "core/importers/metashape_xml.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <string>

namespace mvbrdf::importers {
namespace {

std::filesystem::path Write(const std::string& name, const std::string& text) {
  const std::filesystem::path path = std::filesystem::path(testing::TempDir()) / name;
  std::ofstream(path) << text;
  return path;
}

// One sensor (160x120, f 200, cx 10, cy -6, b1 3, distortion with distinct
// p1, p2), camera "A" rotated 90 degrees about the camera's z axis with its
// centre at (1, 2, 3) in the chunk, a chunk transform with scale 2, and an
// unaligned camera "B".
constexpr double kF = 200, kCx = 10, kCy = -6, kB1 = 3, kK1 = 0.05, kK2 = -0.02, kK3 = 0.01, kP1 = 0.001, kP2 = -0.002;
std::string Document(const std::string& extra_calibration = "", const std::string& sensor_id = "0",
                     const std::string& root = "document") {
  return "<?xml version=\"1.0\"?>\n<" + root +
         " version=\"1.5.0\">\n"
         " <chunk label=\"Chunk 1\">\n"
         "  <sensors>\n"
         "   <sensor id=\"0\" label=\"cam\" type=\"frame\">\n"
         "    <resolution width=\"160\" height=\"120\"/>\n"
         "    <calibration type=\"frame\" class=\"initial\"><resolution width=\"160\" height=\"120\"/><f>1</f>"
         "</calibration>\n"
         "    <calibration type=\"frame\" class=\"adjusted\">\n"
         "     <resolution width=\"160\" height=\"120\"/>\n"
         "     <f>200</f><cx>10</cx><cy>-6</cy><b1>3</b1><k1>0.05</k1><k2>-0.02</k2><k3>0.01</k3>"
         "<p1>0.001</p1><p2>-0.002</p2>" +
         extra_calibration +
         "\n    </calibration>\n"
         "   </sensor>\n"
         "  </sensors>\n"
         "  <cameras>\n"
         "   <camera id=\"0\" sensor_id=\"" +
         sensor_id +
         "\" label=\"A\">\n"
         "    <transform>0 -1 0 1  1 0 0 2  0 0 1 3  0 0 0 1</transform>\n"
         "   </camera>\n"
         "   <group id=\"0\" label=\"g\"><camera id=\"1\" sensor_id=\"0\" label=\"B\"/></group>\n"
         "  </cameras>\n"
         "  <transform>\n"
         "   <rotation>1 0 0  0 0 -1  0 1 0</rotation>\n"
         "   <translation>10 20 30</translation>\n"
         "   <scale>2</scale>\n"
         "  </transform>\n"
         " </chunk>\n"
         "</" +
         root + ">\n";
}

TEST(MetashapeXml, ConventionsAgainstMetashapesOwnProjection) {
  std::vector<std::string> warnings;
  auto cameras = ReadMetashapeCameras(Write("ms.xml", Document()), &warnings);
  ASSERT_TRUE(cameras.ok()) << cameras.status();
  ASSERT_EQ(cameras->size(), 1u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("camera[label=B]: no transform"), std::string::npos) << warnings[0];
  const v1::Camera& c = (*cameras)[0];
  EXPECT_EQ(c.name(), "A");
  EXPECT_EQ(c.width(), 160u);
  EXPECT_EQ(c.height(), 120u);
  EXPECT_DOUBLE_EQ(c.intrinsics().fx(), kF + kB1);
  EXPECT_DOUBLE_EQ(c.intrinsics().fy(), kF);
  EXPECT_DOUBLE_EQ(c.intrinsics().cx(), 80 + kCx - 0.5);
  EXPECT_DOUBLE_EQ(c.intrinsics().cy(), 60 + kCy - 0.5);
  ASSERT_EQ(c.intrinsics().distortion_size(), 5);
  EXPECT_DOUBLE_EQ(c.intrinsics().distortion(2), kP2);  // OpenCV p1 = Metashape p2
  EXPECT_DOUBLE_EQ(c.intrinsics().distortion(3), kP1);

  // A world point, projected by the manual's frame-camera model from the
  // XML's own numbers (pixel origin at the image corner), and by OpenCV from
  // the imported camera (origin at the top-left pixel's centre).
  // world = s R_chunk p_chunk + t_chunk; p_chunk = R_cam p_cam + c.
  const double p_cam[3] = {0.1, -0.07, 2.0};
  const double p_chunk[3] = {-p_cam[1] + 1, p_cam[0] + 2, p_cam[2] + 3};
  const double world[3] = {2 * p_chunk[0] + 10, 2 * -p_chunk[2] + 20, 2 * p_chunk[1] + 30};
  const double x = p_cam[0] / p_cam[2], y = p_cam[1] / p_cam[2], r2 = x * x + y * y;
  const double radial = 1 + kK1 * r2 + kK2 * r2 * r2 + kK3 * r2 * r2 * r2;
  const double xd = x * radial + kP1 * (r2 + 2 * x * x) + 2 * kP2 * x * y;
  const double yd = y * radial + kP2 * (r2 + 2 * y * y) + 2 * kP1 * x * y;
  const double u_metashape = 80 + kCx + xd * (kF + kB1), v_metashape = 60 + kCy + yd * kF;

  cv::Matx33d R(c.cam_from_world().rotation().data());
  cv::Vec3d rvec;
  cv::Rodrigues(R, rvec);
  cv::Vec3d tvec(c.cam_from_world().translation().data());
  cv::Matx33d K(c.intrinsics().fx(), 0, c.intrinsics().cx(), 0, c.intrinsics().fy(), c.intrinsics().cy(), 0, 0, 1);
  std::vector<double> dist(c.intrinsics().distortion().begin(), c.intrinsics().distortion().end());
  std::vector<cv::Point2d> uv;
  cv::projectPoints(std::vector<cv::Point3d>{{world[0], world[1], world[2]}}, rvec, tvec, K, dist, uv);
  EXPECT_NEAR(uv[0].x, u_metashape - 0.5, 1e-9);
  EXPECT_NEAR(uv[0].y, v_metashape - 0.5, 1e-9);
  // The camera-frame point itself: R world + t = p_cam (the rotation's
  // direction and the chunk scale divided out).
  for (int i = 0; i < 3; ++i) {
    double v = c.cam_from_world().translation(i);
    for (int j = 0; j < 3; ++j) v += c.cam_from_world().rotation(i * 3 + j) * world[j];
    EXPECT_NEAR(v, 2 * p_cam[i], 1e-12) << i;  // world units are twice the chunk's
  }
}

// A camera in a component: chunk_from_camera = component * camera. Camera "C"
// sits in a component (90 degrees about x, scale 0.5, shifted) with its
// transform written so that component * transform is camera A's: it must
// come out with A's pose.
TEST(MetashapeXml, ComponentTransform) {
  std::string xml = Document();
  const std::string component =
      "  <components><component id=\"0\" label=\"Component 1\"><transform>"
      "<rotation>1 0 0  0 0 -1  0 1 0</rotation><translation>4 5 6</translation><scale>0.5</scale>"
      "</transform></component></components>\n";
  xml.insert(xml.find("  <cameras>"), component);
  // component^-1 * A: rotation R_c^T R_A, translation R_c^T (c_A - t_c) / s.
  // R_c^T = [1 0 0; 0 0 1; 0 -1 0]; R_A = [0 -1 0; 1 0 0; 0 0 1]; c_A - t_c = (-3, -3, -3).
  xml.insert(xml.find("   <group"),
             "   <camera id=\"2\" sensor_id=\"0\" component_id=\"0\" label=\"C\">\n"
             "    <transform>0 -1 0 -6  0 0 1 -6  -1 0 0 6  0 0 0 1</transform>\n   </camera>\n");
  auto cameras = ReadMetashapeCameras(Write("ms_component.xml", xml));
  ASSERT_TRUE(cameras.ok()) << cameras.status();
  ASSERT_EQ(cameras->size(), 2u);
  const v1::Camera &a = (*cameras)[0], &c = (*cameras)[1];
  EXPECT_EQ(c.name(), "C");
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(c.cam_from_world().rotation(i), a.cam_from_world().rotation(i), 1e-15) << i;
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(c.cam_from_world().translation(i), a.cam_from_world().translation(i), 1e-13) << i;
  }
  // Without the component the pose differs (the component is applied).
  xml.replace(xml.find(" component_id=\"0\""), std::strlen(" component_id=\"0\""), "");
  auto plain = ReadMetashapeCameras(Write("ms_component.xml", xml));
  ASSERT_TRUE(plain.ok()) << plain.status();
  EXPECT_GT(std::abs((*plain)[1].cam_from_world().translation(0) - a.cam_from_world().translation(0)), 0.1);
}

TEST(MetashapeXml, BadInputsNameFileAndElement) {
  struct Case {
    std::string xml, expected;
  };
  for (const Case& c : std::vector<Case>{
           {Document("", "0", "opencv_storage"), "ms_bad.xml: <opencv_storage>: unknown root element"},
           {Document("", "7"), "ms_bad.xml: chunk/cameras/camera[label=A]: sensor_id \"7\" names no sensor"},
           {Document("<b2>0.5</b2>"), "ms_bad.xml: chunk/sensors/sensor[id=0]/calibration/b2: must be 0 (skew"},
           {Document("<k4>0.1</k4>"), "calibration/k4: must be 0"},
           {"<document><chunk><cameras/>", "ms_bad.xml: not readable as XML"},
       }) {
    auto cameras = ReadMetashapeCameras(Write("ms_bad.xml", c.xml));
    ASSERT_FALSE(cameras.ok()) << c.expected;
    EXPECT_EQ(cameras.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(std::string(cameras.status().message()).find(c.expected), std::string::npos) << cameras.status();
  }
  EXPECT_EQ(ReadMetashapeCameras("/nonexistent/x.xml").status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace mvbrdf::importers
