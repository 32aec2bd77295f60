#include "core/scene/camera_model.h"

#include <gtest/gtest.h>

#include <cmath>

namespace mvbrdf::scene {
namespace {

constexpr double kTolerance = 1e-12;

// A camera at (0, 0, -5) looking along world +z, rotated 30 degrees about its
// axis so that x and y mix: R rows are the camera axes in world coordinates.
CameraModel TiltedCamera(Projection projection) {
  CameraModel c;
  c.width = 160;
  c.height = 120;
  c.cx = 79.5;
  c.cy = 59.5;
  c.projection = projection;
  if (projection == Projection::kOrthographic) {
    c.pixel_size = 0.02;
  } else {
    c.fx = c.fy = 200.0;
  }
  const double a = 30.0 * M_PI / 180.0;
  const glm::dvec3 x(std::cos(a), std::sin(a), 0.0), y(-std::sin(a), std::cos(a), 0.0), z(0.0, 0.0, 1.0);
  c.cam_from_world_rotation = glm::transpose(glm::dmat3(x, y, z));
  c.cam_from_world_translation = -(c.cam_from_world_rotation * glm::dvec3(0.0, 0.0, -5.0));
  return c;
}

TEST(CameraModelTest, OrthographicProjectionIsAffineInCameraXY) {
  const CameraModel c = TiltedCamera(Projection::kOrthographic);
  const double a = 30.0 * M_PI / 180.0;
  // A world point one unit along the camera's x axis, at any depth, lands
  // 1 / pixel_size = 50 pixels right of the principal point.
  for (double depth : {0.5, 5.0, 50.0}) {
    const glm::dvec3 p = glm::dvec3(std::cos(a), std::sin(a), 0.0) + glm::dvec3(0.0, 0.0, depth - 5.0);
    const glm::dvec2 pixel = c.Project(p);
    EXPECT_NEAR(pixel.x, 79.5 + 50.0, 1e-9) << depth;
    EXPECT_NEAR(pixel.y, 59.5, 1e-9) << depth;
    EXPECT_EQ(c.ProjectUndistorted(p), pixel);
  }
  // (-0.3, 0.4) in camera x, y: pixel (79.5 - 15, 59.5 + 20).
  const glm::dmat3 world_from_cam = glm::transpose(c.cam_from_world_rotation);
  const glm::dvec3 p = world_from_cam * glm::dvec3(-0.3, 0.4, 2.0) + glm::dvec3(0.0, 0.0, -5.0);
  EXPECT_NEAR(c.Project(p).x, 64.5, 1e-9);
  EXPECT_NEAR(c.Project(p).y, 79.5, 1e-9);
  // Behind the plane z_cam = 0: not seen.
  EXPECT_TRUE(std::isnan(c.Project(glm::dvec3(0.0, 0.0, -6.0)).x));
  // The pinhole of the same pose divides by depth.
  const CameraModel pinhole = TiltedCamera(Projection::kPinhole);
  EXPECT_NEAR(pinhole.Project(p).x, 79.5 - 200.0 * 0.3 / 2.0, 1e-9);
}

// Supersampled(c, s): a point that projects to (u, v) in c projects to
// ((u + 0.5) s - 0.5, (v + 0.5) s - 0.5), so pixel (x, y)'s area is exactly
// subpixels [x s, (x + 1) s) x [y s, (y + 1) s); the lens (normalised
// coordinates) and the pose are the same.
TEST(CameraModelTest, SupersampledSplitsEachPixelIntoSBySSubpixels) {
  for (Projection projection : {Projection::kPinhole, Projection::kOrthographic}) {
    CameraModel c = TiltedCamera(projection);
    c.distortion[0] = -0.05;
    const CameraModel fine = Supersampled(c, 3);
    EXPECT_EQ(fine.width, 480);
    EXPECT_EQ(fine.height, 360);
    EXPECT_EQ(fine.distortion, c.distortion);
    EXPECT_EQ(fine.CenterInWorld(), c.CenterInWorld());
    const glm::dmat3 world_from_cam = glm::transpose(c.cam_from_world_rotation);
    for (const glm::dvec3& q : {glm::dvec3(-0.3, 0.4, 2.0), glm::dvec3(0.5, -0.2, 4.0), glm::dvec3(0.0, 0.0, 1.0)}) {
      const glm::dvec3 p = world_from_cam * q + glm::dvec3(0.0, 0.0, -5.0);
      const glm::dvec2 coarse = c.Project(p), subpixel = fine.Project(p);
      EXPECT_NEAR(subpixel.x, (coarse.x + 0.5) * 3.0 - 0.5, 1e-9);
      EXPECT_NEAR(subpixel.y, (coarse.y + 0.5) * 3.0 - 0.5, 1e-9);
    }
    EXPECT_EQ(Supersampled(c, 1).cx, c.cx);
  }
}

// shared/NOTES.md's v (surface -> camera): towards the centre for a pinhole,
// the constant -z axis for an orthographic camera.
TEST(CameraModelTest, ViewDirectionIsConstantForAnOrthographicCamera) {
  const CameraModel ortho = TiltedCamera(Projection::kOrthographic);
  const CameraModel pinhole = TiltedCamera(Projection::kPinhole);
  for (const glm::dvec3& p : {glm::dvec3(0.0), glm::dvec3(1.0, -0.5, 0.3), glm::dvec3(-2.0, 1.0, 3.0)}) {
    const glm::dvec3 v = ortho.ViewDirection(p);
    EXPECT_NEAR(v.x, 0.0, kTolerance);
    EXPECT_NEAR(v.y, 0.0, kTolerance);
    EXPECT_NEAR(v.z, -1.0, kTolerance);
    const glm::dvec3 towards_centre = glm::normalize(glm::dvec3(0.0, 0.0, -5.0) - p);
    EXPECT_NEAR(glm::length(pinhole.ViewDirection(p) - towards_centre), 0.0, kTolerance);
    // The float form used by the renderers and the Samples agrees.
    const glm::vec3 vf = ViewDirection(glm::vec4(ortho.ViewOrigin()), glm::vec3(p));
    EXPECT_NEAR(glm::length(glm::dvec3(vf) - v), 0.0, 1e-6);
  }
  EXPECT_EQ(ortho.ViewOrigin().w, 0.0);
  EXPECT_EQ(pinhole.ViewOrigin().w, 1.0);
}

TEST(CameraModelTest, ProtoRoundTripKeepsTheModel) {
  v1::Camera message;
  message.set_model(v1::ORTHOGRAPHIC);
  message.set_pixel_size(0.25);
  message.mutable_intrinsics()->set_cx(3.0);
  const CameraModel m = CameraModelFromProto(message);
  EXPECT_TRUE(m.orthographic());
  EXPECT_EQ(m.pixel_size, 0.25);
  EXPECT_EQ(m.PixelScale(), glm::dvec2(4.0));
  v1::Camera back;
  CameraModelToProto(m, &back);
  EXPECT_EQ(back.model(), v1::ORTHOGRAPHIC);
  EXPECT_EQ(back.pixel_size(), 0.25);
  EXPECT_EQ(back.intrinsics().fx(), 0.0);
  // A pinhole written out keeps the model unspecified (older files' form).
  v1::Camera pinhole;
  CameraModelToProto(CameraModelFromProto(v1::Camera()), &pinhole);
  EXPECT_EQ(pinhole.model(), v1::CAMERA_MODEL_UNSPECIFIED);
  EXPECT_EQ(pinhole.pixel_size(), 0.0);
}

}  // namespace
}  // namespace mvbrdf::scene
