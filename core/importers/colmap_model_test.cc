#include "core/importers/colmap_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/importers/import_scene.h"

namespace mvbrdf::importers {
namespace {

constexpr double kTolerance = 1e-12;

TEST(RotationFromQuaternion, QuarterTurnAboutZ) {
  // q = (cos 45°, 0, 0, sin 45°): x -> y, y -> -x (Hamilton, active).
  const double h = std::sqrt(0.5);
  auto r = RotationFromQuaternion(h, 0, 0, h);
  ASSERT_TRUE(r.ok()) << r.status();
  const double want[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  for (int i = 0; i < 9; ++i) EXPECT_NEAR((*r)[i], want[i], kTolerance) << i;
}

TEST(RotationFromQuaternion, HalfTurnAboutXAndNormalisation) {
  // (0, 2, 0, 0) is (0, 1, 0, 0) once normalised: diag(1, -1, -1), the camera
  // of a world seen upside down from +z.
  auto r = RotationFromQuaternion(0, 2, 0, 0);
  ASSERT_TRUE(r.ok()) << r.status();
  const double want[9] = {1, 0, 0, 0, -1, 0, 0, 0, -1};
  for (int i = 0; i < 9; ++i) EXPECT_NEAR((*r)[i], want[i], kTolerance) << i;
}

TEST(RotationFromQuaternion, ZeroIsRefused) { EXPECT_FALSE(RotationFromQuaternion(0, 0, 0, 0).ok()); }

TEST(IntrinsicsFromColmap, PinholeShiftsThePrincipalPointByHalfAPixel) {
  // COLMAP: the centre of the top-left pixel is (0.5, 0.5); mvbrdf: (0, 0).
  auto in = IntrinsicsFromColmap("PINHOLE", {100, 110, 80, 60}, "x");
  ASSERT_TRUE(in.ok()) << in.status();
  EXPECT_EQ(in->fx(), 100);
  EXPECT_EQ(in->fy(), 110);
  EXPECT_EQ(in->cx(), 79.5);
  EXPECT_EQ(in->cy(), 59.5);
  EXPECT_EQ(in->distortion_size(), 0);
}

TEST(IntrinsicsFromColmap, ModelsMapToOpenCvDistortion) {
  auto simple = IntrinsicsFromColmap("SIMPLE_RADIAL", {100, 80, 60, -0.1}, "x");
  ASSERT_TRUE(simple.ok());
  EXPECT_EQ(simple->fy(), 100);
  EXPECT_EQ(simple->cx(), 79.5);
  ASSERT_EQ(simple->distortion_size(), 4);
  EXPECT_EQ(simple->distortion(0), -0.1);
  EXPECT_EQ(simple->distortion(2), 0.0);
  auto radial = IntrinsicsFromColmap("RADIAL", {100, 80, 60, -0.1, 0.02}, "x");
  ASSERT_TRUE(radial.ok());
  EXPECT_EQ(radial->distortion(1), 0.02);
  auto full = IntrinsicsFromColmap("FULL_OPENCV", {100, 101, 80, 60, 1, 2, 3, 4, 5, 6, 7, 8}, "x");
  ASSERT_TRUE(full.ok());
  ASSERT_EQ(full->distortion_size(), 8);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(full->distortion(i), i + 1);  // k1 k2 p1 p2 k3 k4 k5 k6
  auto fisheye = IntrinsicsFromColmap("OPENCV_FISHEYE", {100, 100, 80, 60, 0, 0, 0, 0}, "cameras.txt:3");
  ASSERT_FALSE(fisheye.ok());
  EXPECT_NE(fisheye.status().message().find("cameras.txt:3: unsupported camera model \"OPENCV_FISHEYE\""),
            std::string::npos)
      << fisheye.status();
  EXPECT_FALSE(IntrinsicsFromColmap("PINHOLE", {100, 80, 60}, "x").ok());  // wrong count
}

TEST(ReadColmapModel, TextModelWithCommentsAndEmptyPointLines) {
  const std::filesystem::path dir = std::filesystem::path(testing::TempDir()) / "colmap_text";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "cameras.txt") << "# CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
                                        "1 SIMPLE_PINHOLE 160 120 150 80 60\n";
  // Image 2 is listed first and has an empty POINTS2D line; the order is by IMAGE_ID.
  std::ofstream(dir / "images.txt") << "# two lines per image\n"
                                       "2 1 0 0 0 0 0 3 1 b/0001.png\n"
                                       "\n"
                                       "1 0 1 0 0 0.5 0 4 1 a/0001.png\n"
                                       "10.5 20.5 -1 11 12 3\n";
  auto cameras = ReadColmapModel(dir, {ColmapCameraName::kDirectory});
  ASSERT_TRUE(cameras.ok()) << cameras.status();
  ASSERT_EQ(cameras->size(), 2u);
  EXPECT_EQ((*cameras)[0].name(), "a");
  EXPECT_EQ((*cameras)[0].cam_from_world().rotation(4), -1.0);
  EXPECT_EQ((*cameras)[0].cam_from_world().translation(0), 0.5);
  EXPECT_EQ((*cameras)[1].name(), "b");
  EXPECT_EQ((*cameras)[1].intrinsics().cx(), 79.5);
  // By stem both are "0001".
  auto duplicate = ReadColmapModel(dir, {ColmapCameraName::kStem});
  ASSERT_FALSE(duplicate.ok());
  EXPECT_NE(duplicate.status().message().find("both make camera \"0001\""), std::string::npos) << duplicate.status();
}

// Projects a world point with a pinhole camera (no distortion): (u, v).
std::array<double, 2> Project(const v1::Camera& c, const std::array<double, 3>& p) {
  const auto& r = c.cam_from_world().rotation();
  const auto& t = c.cam_from_world().translation();
  double x[3];
  for (int i = 0; i < 3; ++i) x[i] = r[3 * i] * p[0] + r[3 * i + 1] * p[1] + r[3 * i + 2] * p[2] + t[i];
  return {c.intrinsics().fx() * x[0] / x[2] + c.intrinsics().cx(),
          c.intrinsics().fy() * x[1] / x[2] + c.intrinsics().cy()};
}

TEST(TransformCamera, SeesTheMappedPointAtTheSamePixel) {
  // A camera in the calibration's world, and a similarity (scale 2.5, a
  // rotation about an oblique axis, a shift) into the mesh's world.
  v1::Camera c;
  c.mutable_intrinsics()->set_fx(150);
  c.mutable_intrinsics()->set_fy(140);
  c.mutable_intrinsics()->set_cx(79.5);
  c.mutable_intrinsics()->set_cy(59.5);
  auto rc = RotationFromQuaternion(0.9, 0.1, -0.3, 0.2);
  ASSERT_TRUE(rc.ok());
  for (double v : *rc) c.mutable_cam_from_world()->add_rotation(v);
  for (double v : {0.1, -0.2, 3.0}) c.mutable_cam_from_world()->add_translation(v);
  auto r = RotationFromQuaternion(0.5, -0.4, 0.6, 0.1);
  ASSERT_TRUE(r.ok());
  const double s = 2.5;
  const double t[3] = {1.0, -2.0, 0.5};
  std::vector<double> m(16, 0.0);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m[4 * i + j] = s * (*r)[3 * i + j];
    m[4 * i + 3] = t[i];
  }
  m[15] = 1.0;
  auto w = SimilarityFromMatrix(m, "--transform");
  ASSERT_TRUE(w.ok()) << w.status();
  EXPECT_NEAR(w->scale, s, kTolerance);
  const v1::Camera moved = TransformCamera(c, *w);
  for (const std::array<double, 3>& pc : {std::array<double, 3>{0, 0, 0}, {0.3, -0.2, 0.4}, {-0.5, 0.1, 1.0}}) {
    std::array<double, 3> pw{};
    for (int i = 0; i < 3; ++i)
      pw[i] = s * ((*r)[3 * i] * pc[0] + (*r)[3 * i + 1] * pc[1] + (*r)[3 * i + 2] * pc[2]) + t[i];
    const auto a = Project(c, pc);
    const auto b = Project(moved, pw);
    EXPECT_NEAR(a[0], b[0], 1e-9);
    EXPECT_NEAR(a[1], b[1], 1e-9);
  }
  // A telecentric camera's pixel is s times as large in the mesh's world.
  c.set_pixel_size(0.01);
  EXPECT_NEAR(TransformCamera(c, *w).pixel_size(), 0.025, kTolerance);
}

TEST(SimilarityFromMatrix, RoundedRotationBecomesOrthonormal) {
  // A 30° turn about z, scale 2, written with 6 decimals (error ~3e-7).
  const std::vector<double> m = {1.732051, -1.0, 0, 0.5, 1.0, 1.732051, 0, 0, 0, 0, 2.0, 0, 0, 0, 0, 1};
  auto w = SimilarityFromMatrix(m, "f");
  ASSERT_TRUE(w.ok()) << w.status();
  const auto& r = w->rotation;
  double worst = 0.0;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const double dot = r[3 * i] * r[3 * j] + r[3 * i + 1] * r[3 * j + 1] + r[3 * i + 2] * r[3 * j + 2];
      worst = std::max(worst, std::abs(dot - (i == j ? 1.0 : 0.0)));
    }
  }
  EXPECT_LT(worst, 1e-14);
  EXPECT_NEAR(r[0], std::sqrt(3.0) / 2, 1e-6);
  EXPECT_NEAR(w->scale, 2.0, 1e-6);
}

TEST(SimilarityFromMatrix, RefusesShearMirrorsAndWrongCounts) {
  std::vector<double> shear = {1, 0.1, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  EXPECT_NE(SimilarityFromMatrix(shear, "f").status().message().find("not a similarity"), std::string::npos);
  std::vector<double> mirror = {-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  EXPECT_NE(SimilarityFromMatrix(mirror, "f").status().message().find("a mirror"), std::string::npos);
  EXPECT_NE(SimilarityFromMatrix({1, 0, 0}, "f").status().message().find("expected 16 numbers"), std::string::npos);
}

}  // namespace
}  // namespace mvbrdf::importers
