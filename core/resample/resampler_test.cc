#include "core/resample/resampler.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <glm/gtc/matrix_transform.hpp>
#include <limits>
#include <vector>

#include "core/gl/gl_api.h"
#include "core/resample/resample_test_util.h"
#include "core/scene/mesh_loader.h"

namespace mvbrdf::resample {
namespace {

using testing::CrossPlaneZ;
using testing::InsideSquare;
using testing::LookAtCamera;
using testing::MakeQuadScene;
using testing::Quad;
using testing::QuadScene;

// Resampled pixel position vs CPU CameraModel::Project, pixels: float
// projection on the GPU and the texture unit's bilinear weights (measured on
// llvmpipe: ~1.2e-4). The frame encodes the pixel position linearly, so a
// bilinear lookup reproduces it; a half-pixel convention error would be 250x this.
constexpr double kPixelTolerance = 2e-3;
// At silhouettes the footprint's background pixels are dropped and the
// weights renormalised: the sample moves towards the surface by less than one
// pixel (the footprint is 1 x 1 pixel).
constexpr double kSilhouetteBandPixels = 1.0;
// Geometry atlas vs the analytic surface point of the texel centre, world
// units, over a scene of size ~2 (measured: 4e-7), and unit normals (measured 1e-7).
constexpr double kPositionTolerance = 2e-6;
constexpr double kNormalTolerance = 1e-6;
// Texels whose expected pixel is closer than this to the edge of the valid
// image region [0, w-1] x [0, h-1] are not compared (float rounding decides).
constexpr double kImageBorderBand = 0.01;
// Occlusion boundary band, camera pixels: the depth map has the camera's
// resolution and is looked up bilinearly, so within about one pixel of the
// occluder's silhouette the occluder's and the background's depths mix.
// Measured: every misclassified texel is a visible one declared occluded (the
// safe side), at most 0.81 px from the silhouette (270 of ~100k texels with a
// 0.5 px band, 93 with 0.75, none with 1.0). The scene has ~1.1 atlas texels
// per camera pixel, so this is a band of ~1 texel either side.
constexpr double kOcclusionBandPixels = 1.0;
// Hidden texels this far inside the silhouette, camera pixels, are never
// valid (the occluder's colour must not leak into the background's texels).
constexpr double kHiddenBandPixels = 0.1;
// Shadow boundary band, world units at the occluder: about two shadow-map
// texels (2 / 512 rad at ~1 unit from the light) and one atlas texel of the
// plane (~0.012). Measured: 0.001 still passes at these resolutions.
constexpr double kShadowBandWorld = 0.01;

// The ground plane z = 0, |x|, |y| <= 1, facing +z, over UVs [lo, hi]^2.
Quad GroundQuad(double uv_lo, double uv_hi) {
  Quad q;
  q.origin = {-1.0, -1.0, 0.0};
  q.edge_s = {2.0, 0.0, 0.0};
  q.edge_t = {0.0, 2.0, 0.0};
  q.uv_min = glm::dvec2(uv_lo);
  q.uv_max = glm::dvec2(uv_hi);
  return q;
}

// A unit quad through the ground plane along y = 0, tilted by `degrees` about
// the x axis (half of it below the ground), over UVs [0.70, 0.98] x [0.02, 0.66].
Quad TiltedQuad(double degrees) {
  const double tilt = degrees * 3.14159265358979323846 / 180.0;
  Quad q;
  q.origin = {-0.5, -0.5 * std::cos(tilt), -0.5 * std::sin(tilt)};
  q.edge_s = {1.0, 0.0, 0.0};
  q.edge_t = {0.0, std::cos(tilt), std::sin(tilt)};
  q.uv_min = glm::dvec2(0.70, 0.02);
  q.uv_max = glm::dvec2(0.98, 0.66);
  return q;
}

// A square |x|, |y| <= half at height z facing +z, over UVs [lo, hi]^2.
Quad SquareQuad(double half, double z, double uv_lo, double uv_hi) {
  Quad q;
  q.origin = {-half, -half, z};
  q.edge_s = {2.0 * half, 0.0, 0.0};
  q.edge_t = {0.0, 2.0 * half, 0.0};
  q.uv_min = glm::dvec2(uv_lo);
  q.uv_max = glm::dvec2(uv_hi);
  return q;
}

// Frame whose pixel (x, y) holds (x / width, y / height, 0.25): a bilinear
// lookup at pixel position p returns (p.x / width, p.y / height, 0.25).
cv::Mat PixelPositionFrame(int width, int height) {
  cv::Mat frame(height, width, CV_32FC3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      frame.at<cv::Vec3f>(y, x) = cv::Vec3f(static_cast<float>(x) / width, static_cast<float>(y) / height, 0.25f);
    }
  }
  return frame;
}

bool Valid(const cv::Mat& rgba, int x, int y) { return rgba.at<cv::Vec4f>(y, x)[3] > 0.5f; }

class ResamplerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
    ASSERT_TRUE(context.ok()) << context.status();
    context_ = std::move(*context);
  }

  std::unique_ptr<Resampler> Make(const QuadScene& scene, const std::vector<scene::CameraModel>& cameras,
                                  const std::vector<scene::Light>& lights = {}, const ResamplerOptions& options = {}) {
    auto resampler = Resampler::Create(*context_, scene.atlas, cameras, lights, options);
    EXPECT_TRUE(resampler.ok()) << resampler.status();
    if (!resampler.ok()) return nullptr;
    const absl::Status status = (*resampler)->SetFrame(scene.positions);
    EXPECT_TRUE(status.ok()) << status;
    return std::move(*resampler);
  }

  std::unique_ptr<gl::EglContext> context_;
};

// Does the camera ray through `pixel` (distorted image coordinates) hit one
// of the scene's quads?
bool PixelSeesScene(const QuadScene& scene, const scene::CameraModel& camera, const glm::dvec2& pixel) {
  const glm::dmat3 world_from_cam = glm::transpose(camera.cam_from_world_rotation);
  glm::dvec3 origin = camera.CenterInWorld(), dir;
  if (camera.orthographic()) {  // parallel rays from the plane z_cam = 0
    const glm::dvec2 xy = (pixel - glm::dvec2(camera.cx, camera.cy)) * camera.pixel_size;
    origin = world_from_cam * (glm::dvec3(xy, 0.0) - camera.cam_from_world_translation);
    dir = world_from_cam * glm::dvec3(0.0, 0.0, 1.0);
  } else {
    const glm::dvec2 u = camera.Undistort({(pixel.x - camera.cx) / camera.fx, (pixel.y - camera.cy) / camera.fy});
    dir = world_from_cam * glm::dvec3(u.x, u.y, 1.0);
  }
  for (const Quad& q : scene.quads) {
    const glm::dvec3 n = glm::cross(q.edge_s, q.edge_t);
    const double denom = glm::dot(dir, n);
    if (std::abs(denom) < 1e-12) continue;
    const double t = glm::dot(q.origin - origin, n) / denom;
    if (t <= 0.0) continue;
    const glm::dvec3 r = origin + t * dir - q.origin;
    // Parallelogram coordinates from the 2x2 normal equations.
    const double ss = glm::dot(q.edge_s, q.edge_s), st = glm::dot(q.edge_s, q.edge_t), tt = glm::dot(q.edge_t, q.edge_t);
    const double rs = glm::dot(r, q.edge_s), rt = glm::dot(r, q.edge_t);
    const double det = ss * tt - st * st;
    const double a = (rs * tt - rt * st) / det, b = (rt * ss - rs * st) / det;
    if (a >= 0.0 && a <= 1.0 && b >= 0.0 && b <= 1.0) return true;
  }
  return false;
}

// Compares every covered texel's sample with CPU Project. Texels whose
// bilinear footprint (with a one-pixel margin) lies entirely on the scene are
// "interior" and must match to kPixelTolerance; at silhouettes the resampler
// drops background pixels from the footprint and renormalises, which moves
// the sample by less than kSilhouetteBandPixels.
struct ProjectionCheck {
  double max_error = 0.0;       // interior texels
  double max_band_error = 0.0;  // silhouette texels
  double max_distortion_shift = 0.0;  // |distorted - pinhole| pixel, for sanity
  int covered = 0;
  int valid = 0;
  int interior = 0;
  int interior_valid = 0;
};

ProjectionCheck CheckProjection(const QuadScene& scene, const scene::CameraModel& camera, const cv::Mat& rgba) {
  ProjectionCheck check;
  scene::CameraModel pinhole = camera;
  pinhole.distortion.assign(8, 0.0);
  for (int y = 0; y < scene.atlas.size; ++y) {
    for (int x = 0; x < scene.atlas.size; ++x) {
      const auto point = scene.TexelPoint(x, y);
      if (!point.has_value()) continue;
      ++check.covered;
      const glm::dvec2 expected = camera.Project(point->second);
      bool interior = true;
      const glm::dvec2 base(std::floor(expected.x), std::floor(expected.y));
      for (int dy = -1; dy <= 2 && interior; ++dy) {
        for (int dx = -1; dx <= 2 && interior; ++dx) interior = PixelSeesScene(scene, camera, base + glm::dvec2(dx, dy));
      }
      check.interior += interior ? 1 : 0;
      if (!Valid(rgba, x, y)) continue;
      ++check.valid;
      check.interior_valid += interior ? 1 : 0;
      const cv::Vec4f& s = rgba.at<cv::Vec4f>(y, x);
      const glm::dvec2 actual(s[0] * camera.width, s[1] * camera.height);
      double& max_error = interior ? check.max_error : check.max_band_error;
      max_error = std::max(max_error, glm::length(actual - expected));
      check.max_distortion_shift =
          std::max(check.max_distortion_shift, glm::length(expected - pinhole.Project(point->second)));
      EXPECT_NEAR(s[2], 0.25f, 1e-6f);
    }
  }
  return check;
}

// The camera's surface map holds, at every pixel centre, the exact surface
// point the pixel shows, its normal and its atlas texel.
TEST_F(ResamplerTest, SurfaceMapHoldsThePointUnderEachPixelCentre) {
  const QuadScene scene = MakeQuadScene({GroundQuad(0.05, 0.95)}, 256);
  const scene::CameraModel camera = LookAtCamera({0.4, -0.5, 3.0}, {0.0, 0.0, 0.0}, 320, 240, 225.0);
  auto resampler = Make(scene, {camera});
  ASSERT_NE(resampler, nullptr);
  auto surface = resampler->Surface(0);
  ASSERT_TRUE(surface.ok()) << surface.status();
  ASSERT_EQ(surface->position_texel.rows, 240);
  ASSERT_EQ(surface->position_texel.cols, 320);
  const Quad& q = scene.quads[0];
  const glm::dvec3 origin = camera.CenterInWorld();
  int covered = 0, texel_matches = 0;
  double max_error = 0.0;
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; ++x) {
      const cv::Vec4f& p = surface->position_texel.at<cv::Vec4f>(y, x);
      // The analytic hit of the pixel centre's ray with the plane z = 0.
      const glm::dvec3 dir = glm::transpose(camera.cam_from_world_rotation) *
                             glm::dvec3((x - camera.cx) / camera.fx, (y - camera.cy) / camera.fy, 1.0);
      const double t = -origin.z / dir.z;
      const glm::dvec3 hit = origin + t * dir;
      const double a = (hit.x - q.origin.x) / q.edge_s.x, b = (hit.y - q.origin.y) / q.edge_t.y;
      const bool inside = a > 0.002 && a < 0.998 && b > 0.002 && b < 0.998;  // away from the rim
      if (!inside) continue;
      ASSERT_GT(p[3], 0.0f) << x << ", " << y;
      ++covered;
      max_error = std::max(max_error, glm::length(glm::dvec3(p[0], p[1], p[2]) - hit));
      const cv::Vec4f& n = surface->normal.at<cv::Vec4f>(y, x);
      EXPECT_NEAR(n[2], 1.0f, 1e-5f);
      const glm::dvec2 uv = q.uv_min + glm::dvec2(a, b) * (q.uv_max - q.uv_min);
      const int texel = static_cast<int>(std::floor((1.0 - uv.y) * 256)) * 256 + static_cast<int>(std::floor(uv.x * 256));
      texel_matches += static_cast<int>(p[3]) - 1 == texel ? 1 : 0;
    }
  }
  EXPECT_GT(covered, 20000);
  EXPECT_LT(max_error, kPositionTolerance * 10);
  // Texel boundaries decide on float rounding for a few pixel centres.
  EXPECT_GT(texel_matches, covered * 99 / 100);
}

TEST_F(ResamplerTest, PlaneSamplesTheProjectedPixel) {
  const QuadScene scene = MakeQuadScene({GroundQuad(0.05, 0.95)}, 256);
  const scene::CameraModel camera = LookAtCamera({0.4, -0.5, 3.0}, {0.0, 0.0, 0.0}, 640, 480, 450.0);
  auto resampler = Make(scene, {camera});
  ASSERT_NE(resampler, nullptr);
  auto rgba = resampler->ResampleCamera(0, PixelPositionFrame(camera.width, camera.height));
  ASSERT_TRUE(rgba.ok()) << rgba.status();
  ASSERT_EQ(rgba->type(), CV_32FC4);
  ASSERT_EQ(rgba->rows, 256);
  const ProjectionCheck check = CheckProjection(scene, camera, *rgba);
  EXPECT_GT(check.covered, 200 * 200);
  // The whole plane is in view and unoccluded: every texel off the silhouette
  // is valid, and only texels at the very rim (footprint mostly background)
  // are dropped.
  EXPECT_EQ(check.interior_valid, check.interior);
  EXPECT_GT(check.interior, check.covered * 9 / 10);
  EXPECT_LT(check.covered - check.valid, check.covered / 100);
  EXPECT_LT(check.max_error, kPixelTolerance);
  EXPECT_LT(check.max_band_error, kSilhouetteBandPixels);
  // Uncovered texels are invalid and zero.
  for (int y = 0; y < 256; ++y) {
    for (int x = 0; x < 256; ++x) {
      if (scene.atlas.triangle_id.at<int32_t>(y, x) < 0) {
        ASSERT_EQ(rgba->at<cv::Vec4f>(y, x), cv::Vec4f(0, 0, 0, 0)) << x << ", " << y;
      }
    }
  }
}

TEST_F(ResamplerTest, DistortedCameraSamplesTheDistortedPixel) {
  const QuadScene scene = MakeQuadScene({GroundQuad(0.05, 0.95)}, 256);
  scene::CameraModel camera = LookAtCamera({0.4, -0.5, 3.0}, {0.0, 0.0, 0.0}, 640, 480, 500.0);
  camera.cx += 3.7;  // off-centre on purpose
  camera.cy -= 2.2;
  camera.distortion = {-0.25, 0.08, 0.002, -0.001, 0.01, 0.0, 0.0, 0.0};
  auto resampler = Make(scene, {camera});
  ASSERT_NE(resampler, nullptr);
  auto rgba = resampler->ResampleCamera(0, PixelPositionFrame(camera.width, camera.height));
  ASSERT_TRUE(rgba.ok()) << rgba.status();
  const ProjectionCheck check = CheckProjection(scene, camera, *rgba);
  EXPECT_EQ(check.interior_valid, check.interior);
  EXPECT_GT(check.interior, check.covered * 9 / 10);
  EXPECT_LT(check.covered - check.valid, check.covered / 100);
  EXPECT_LT(check.max_error, kPixelTolerance);
  EXPECT_LT(check.max_band_error, kSilhouetteBandPixels);
  EXPECT_GT(check.max_distortion_shift, 5.0);  // the distortion matters in this view
}

TEST_F(ResamplerTest, TexelsOutsideTheImageAreInvalid) {
  const QuadScene scene = MakeQuadScene({GroundQuad(0.05, 0.95)}, 256);
  // Close enough that the plane overflows the image on every side.
  scene::CameraModel camera = LookAtCamera({0.1, -0.2, 1.2}, {0.0, 0.0, 0.0}, 320, 240, 300.0);
  camera.distortion = {-0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  auto resampler = Make(scene, {camera});
  ASSERT_NE(resampler, nullptr);
  auto rgba = resampler->ResampleCamera(0, PixelPositionFrame(camera.width, camera.height));
  ASSERT_TRUE(rgba.ok()) << rgba.status();
  int inside = 0, outside = 0, wrong = 0;
  double max_error = 0.0;
  for (int y = 0; y < 256; ++y) {
    for (int x = 0; x < 256; ++x) {
      const auto point = scene.TexelPoint(x, y);
      if (!point.has_value()) continue;
      const glm::dvec2 p = camera.Project(point->second);
      const double margin = std::min({p.x, p.y, camera.width - 1 - p.x, camera.height - 1 - p.y});
      if (std::abs(margin) < kImageBorderBand) continue;
      const bool expected = margin > 0.0;
      (expected ? inside : outside)++;
      if (Valid(*rgba, x, y) != expected) ++wrong;
      if (expected && Valid(*rgba, x, y)) {
        const cv::Vec4f& s = rgba->at<cv::Vec4f>(y, x);
        max_error = std::max(max_error, glm::length(glm::dvec2(s[0] * camera.width, s[1] * camera.height) - p));
      }
    }
  }
  EXPECT_GT(inside, 1000);
  EXPECT_GT(outside, 1000);
  EXPECT_EQ(wrong, 0);
  EXPECT_LT(max_error, kPixelTolerance);
}

TEST_F(ResamplerTest, BackFacingAndGrazingTexelsAreInvalid) {
  const QuadScene scene = MakeQuadScene({GroundQuad(0.05, 0.95)}, 128);
  const scene::CameraModel below = LookAtCamera({0.3, 0.2, -3.0}, {0.0, 0.0, 0.0}, 320, 240, 200.0);
  // ~1.9 degrees above the plane: front-facing but within the 5 degree margin.
  const scene::CameraModel grazing = LookAtCamera({0.0, -30.0, 1.0}, {0.0, 0.0, 0.0}, 320, 240, 2000.0);
  for (const double margin : {5.0, 0.0}) {
    ResamplerOptions options;
    options.grazing_margin_deg = margin;
    auto resampler = Make(scene, {below, grazing}, {}, options);
    ASSERT_NE(resampler, nullptr);
    for (int c = 0; c < 2; ++c) {
      const scene::CameraModel& camera = c == 0 ? below : grazing;
      auto rgba = resampler->ResampleCamera(c, PixelPositionFrame(camera.width, camera.height));
      ASSERT_TRUE(rgba.ok()) << rgba.status();
      int valid = 0;
      for (int y = 0; y < 128; ++y) {
        for (int x = 0; x < 128; ++x) valid += Valid(*rgba, x, y) ? 1 : 0;
      }
      SCOPED_TRACE(::testing::Message() << "camera " << c << ", margin " << margin);
      if (c == 0 || margin > 0.0) {
        EXPECT_EQ(valid, 0);
      } else {
        EXPECT_GT(valid, 1000);  // without the margin the grazing view is kept
      }
    }
  }
}

// A shallow view just outside the grazing margin (6.3 to 8.1 degrees above
// the plane): the plane must not occlude itself. With f = 500 its depth
// changes by up to 1 / (f tan 6.3 deg) = 1.8 % per pixel, more than the 1 %
// tolerance, so the depth lookup has to be exact on planar surfaces.
TEST_F(ResamplerTest, ShallowViewIsNotSelfOccluded) {
  const QuadScene scene = MakeQuadScene({GroundQuad(0.05, 0.95)}, 256);
  const scene::CameraModel camera = LookAtCamera({0.0, -10.0, 1.0}, {0.0, 0.0, 0.0}, 640, 480, 500.0);
  auto resampler = Make(scene, {camera});
  ASSERT_NE(resampler, nullptr);
  auto rgba = resampler->ResampleCamera(0, PixelPositionFrame(camera.width, camera.height));
  ASSERT_TRUE(rgba.ok()) << rgba.status();
  const ProjectionCheck check = CheckProjection(scene, camera, *rgba);
  EXPECT_GT(check.covered, 40000);
  // No self-occlusion: every texel off the silhouette is valid. The plane is
  // so foreshortened that a few percent of its texels sit within a pixel of
  // its rim, where the footprint is mostly background.
  EXPECT_EQ(check.interior_valid, check.interior);
  EXPECT_GT(check.interior, check.covered / 2);  // measured: 35304 of 52900
  EXPECT_LT(check.max_error, kPixelTolerance);
  EXPECT_LT(check.max_band_error, kSilhouetteBandPixels);
}

// Issue #13: an orthographic camera with the same pose, pixel size
// `pixel_size`, moved along its axis so that the nearest of `points` lies at
// z_cam = `nearest_z` (an orthographic camera's depth origin is arbitrary).
scene::CameraModel Orthographic(scene::CameraModel camera, double pixel_size, const std::vector<glm::dvec3>& points,
                                double nearest_z) {
  camera.projection = scene::Projection::kOrthographic;
  camera.fx = camera.fy = 0.0;
  camera.pixel_size = pixel_size;
  double z = std::numeric_limits<double>::max();
  for (const glm::dvec3& p : points) z = std::min(z, camera.CamFromWorld(p).z);
  camera.cam_from_world_translation.z += nearest_z - z;
  return camera;
}

const std::vector<glm::dvec3> kGroundCorners = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};

TEST_F(ResamplerTest, OrthographicPlaneSamplesTheProjectedPixel) {
  const QuadScene scene = MakeQuadScene({GroundQuad(0.05, 0.95)}, 256);
  const scene::CameraModel camera =
      Orthographic(LookAtCamera({0.4, -0.5, 3.0}, {0.0, 0.0, 0.0}, 640, 480, 450.0), 2.9 / 480, kGroundCorners, 1.0);
  auto resampler = Make(scene, {camera});
  ASSERT_NE(resampler, nullptr);
  auto rgba = resampler->ResampleCamera(0, PixelPositionFrame(camera.width, camera.height));
  ASSERT_TRUE(rgba.ok()) << rgba.status();
  const ProjectionCheck check = CheckProjection(scene, camera, *rgba);
  EXPECT_GT(check.covered, 200 * 200);
  EXPECT_EQ(check.interior_valid, check.interior);
  EXPECT_GT(check.interior, check.covered * 9 / 10);
  EXPECT_LT(check.max_error, kPixelTolerance);
  EXPECT_LT(check.max_band_error, kSilhouetteBandPixels);
}

// At a grazing view with the plane z_cam = 0 just in front of the quad, the
// depth changes by more than the relative tolerance between neighbouring
// depth-map pixels; interpolating 1 / z (exact for a pinhole, not here)
// would make the near rows occlude themselves (measured: 8740 of 50140
// interior texels invalid). The facing test's v must be the axis: v towards
// the "centre" on the plane z_cam = 0 made 25670 of them grazing.
TEST_F(ResamplerTest, OrthographicShallowViewIsNotSelfOccluded) {
  const QuadScene scene = MakeQuadScene({GroundQuad(0.05, 0.95)}, 256);
  const scene::CameraModel camera =
      Orthographic(LookAtCamera({0.0, -10.0, 1.0}, {0.0, 0.0, 0.0}, 640, 480, 500.0), 2.2 / 640, kGroundCorners, 0.02);
  auto resampler = Make(scene, {camera});
  ASSERT_NE(resampler, nullptr);
  auto rgba = resampler->ResampleCamera(0, PixelPositionFrame(camera.width, camera.height));
  ASSERT_TRUE(rgba.ok()) << rgba.status();
  const ProjectionCheck check = CheckProjection(scene, camera, *rgba);
  EXPECT_GT(check.covered, 40000);
  EXPECT_EQ(check.interior_valid, check.interior);
  EXPECT_GT(check.interior, check.covered / 3);
  EXPECT_LT(check.max_error, kPixelTolerance);
  RecordProperty("interior", check.interior);
}

TEST_F(ResamplerTest, OccludedTexelsAreInvalidAndBlackIsDistinguishable) {
  // Plane plus a floating square (its own atlas region) between it and the camera.
  const QuadScene scene = MakeQuadScene({GroundQuad(0.02, 0.66), SquareQuad(0.3, 1.0, 0.70, 0.98)}, 512);
  const scene::CameraModel camera = LookAtCamera({0.5, -0.4, 3.0}, {0.0, 0.0, 0.0}, 640, 480, 450.0);
  const glm::dvec3 center = camera.CenterInWorld();
  auto resampler = Make(scene, {camera});
  ASSERT_NE(resampler, nullptr);
  // A black frame: valid texels are (0, 0, 0, 1), invalid ones (0, 0, 0, 0).
  auto rgba = resampler->ResampleCamera(0, cv::Mat(camera.height, camera.width, CV_32FC3, cv::Scalar(0, 0, 0)));
  ASSERT_TRUE(rgba.ok()) << rgba.status();
  int hidden = 0, seen = 0, in_band = 0, wrong = 0, occluder_invalid = 0, not_black = 0, hidden_but_valid = 0;
  for (int y = 0; y < 512; ++y) {
    for (int x = 0; x < 512; ++x) {
      const cv::Vec4f& s = rgba->at<cv::Vec4f>(y, x);
      if (s[0] != 0.0f || s[1] != 0.0f || s[2] != 0.0f || (s[3] != 0.0f && s[3] != 1.0f)) ++not_black;
      const auto point = scene.TexelPoint(x, y);
      if (!point.has_value()) continue;
      if (point->first == 1) {
        occluder_invalid += Valid(*rgba, x, y) ? 0 : 1;
        continue;
      }
      const std::optional<glm::dvec3> cross = CrossPlaneZ(point->second, center, 1.0);
      ASSERT_TRUE(cross.has_value());
      const double inside = InsideSquare(*cross, glm::dvec2(0.0), 0.3);
      const double distance_px = std::abs(inside) * camera.fx / camera.CamFromWorld(*cross).z;
      // Inside the band only the safe error is allowed: hidden texels that
      // are more than kHiddenBandPixels inside the silhouette must be invalid.
      if (inside > 0.0 && distance_px >= kHiddenBandPixels && Valid(*rgba, x, y)) ++hidden_but_valid;
      if (distance_px < kOcclusionBandPixels) {
        ++in_band;
        continue;
      }
      const bool is_hidden = inside > 0.0;
      (is_hidden ? hidden : seen)++;
      if (Valid(*rgba, x, y) == is_hidden) ++wrong;
    }
  }
  EXPECT_GT(hidden, 5000);
  EXPECT_GT(seen, 50000);
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(hidden_but_valid, 0);
  EXPECT_EQ(occluder_invalid, 0);
  EXPECT_EQ(not_black, 0);
  EXPECT_LT(in_band, hidden / 5);  // the band is a thin ring
}

// Two parts of a mesh that interpenetrate (the actor's limbs at its joints, a
// tracked body's arm in its side): a quad tilted 2 degrees through the ground
// plane. Its texels below the ground are hidden from a camera above, but those
// within the relative depth tolerance of the ground pass the depth-map test
// and take the ground's colour (on the actor: cloth texels with 5x their kd,
// most of kd's RMSE). With the depth map alone the tolerance sets that band:
// at the default (1e-3 of the depth, ~3 mm here) 2736 texels more than 1 mm
// below pass, at 1e-4 none; but a tighter one refuses texels at a coarse
// mesh's concave creases, where the depth map's bilinear 1 / z lies in front
// of the surface (CameraVisibilityAgreesWithShadowOfALightAtTheCamera on
// Spot: lit and facing texels refused 451 at 1e-3, 691 at 5e-4, 2386 at
// 1e-4). The exact occluder test (the default) refuses the band at the
// default tolerance: the ground's triangles cross the hidden texels' rays.
TEST_F(ResamplerTest, DepthToleranceSetsTheBandOfTexelsInsideAnotherPartThatPass) {
  const Quad tilted = TiltedQuad(2.0);
  const QuadScene scene = MakeQuadScene({GroundQuad(0.02, 0.66), tilted}, 512);
  const scene::CameraModel camera = LookAtCamera({0.3, -0.2, 3.0}, {0.0, 0.0, 0.0}, 640, 480, 450.0);
  // Valid texels of the tilted quad more than 1 mm under the ground.
  const auto hidden_but_valid = [&](double relative_tolerance, bool exact_occluders) {
    ResamplerOptions options;
    options.relative_depth_tolerance = relative_tolerance;
    options.exact_occluder_test = exact_occluders;
    auto resampler = Make(scene, {camera}, {}, options);
    EXPECT_NE(resampler, nullptr);
    if (resampler == nullptr) return -1;
    auto rgba = resampler->ResampleCamera(0, PixelPositionFrame(camera.width, camera.height));
    EXPECT_TRUE(rgba.ok()) << rgba.status();
    int count = 0, above = 0;
    for (int y = 0; y < 512; ++y) {
      for (int x = 0; x < 512; ++x) {
        const auto point = scene.TexelPoint(x, y);
        if (!point.has_value() || point->first != 1) continue;
        if (point->second.z > 0.01) above += Valid(*rgba, x, y) ? 1 : 0;
        if (point->second.z < -0.001 && Valid(*rgba, x, y)) ++count;
      }
    }
    EXPECT_GT(above, 1000);  // the part above the ground is seen
    return count;
  };
  const ResamplerOptions defaults;
  // The depth map alone: a tight tolerance refuses them, the default lets a
  // band through (measured 2736).
  EXPECT_EQ(hidden_but_valid(1e-4, false), 0);
  EXPECT_GT(hidden_but_valid(defaults.relative_depth_tolerance, false), 1000);
  // The defaults: the ground's triangles cross the hidden texels' rays.
  ASSERT_TRUE(defaults.exact_occluder_test);
  EXPECT_EQ(hidden_but_valid(defaults.relative_depth_tolerance, true), 0);
}

// The same two parts, seen where the tilted quad comes out of the ground: a
// frame that is 1 where a pixel shows the quad and 0 where it shows the
// ground. A texel of the quad just above the ground is visible, but its
// bilinear footprint reaches pixels that show the ground in front of the
// quad's plane; with the exact test those pixels leave the footprint (as
// background pixels do at a silhouette), so no valid texel of the quad takes
// the ground's colour. The depth map alone lets it mix in.
TEST_F(ResamplerTest, PixelsShowingAnotherPartInFrontLeaveTheFootprint) {
  const Quad tilted = TiltedQuad(10.0);
  const double top = tilted.Point(0.0, 1.0).z;  // the quad's highest point above the ground
  const QuadScene scene = MakeQuadScene({GroundQuad(0.02, 0.66), tilted}, 512);
  const scene::CameraModel camera = LookAtCamera({0.3, -0.2, 3.0}, {0.0, 0.0, 0.0}, 320, 240, 225.0);
  // The part each pixel centre shows: the nearest of the two planes' hits.
  const glm::dvec3 center = camera.CenterInWorld();
  const glm::dvec3 tilted_normal = tilted.Normal();
  cv::Mat parts(camera.height, camera.width, CV_32FC3, cv::Scalar(0.5f, 0.5f, 0.5f));
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const glm::dvec3 ray = glm::transpose(camera.cam_from_world_rotation) *
                             glm::dvec3((x - camera.cx) / camera.fx, (y - camera.cy) / camera.fy, 1.0);
      double best = std::numeric_limits<double>::infinity();
      float part = 0.5f;
      const double ground_s = -center.z / ray.z;
      const glm::dvec3 g = center + ground_s * ray;
      if (ground_s > 0.0 && std::abs(g.x) <= 1.0 && std::abs(g.y) <= 1.0) best = ground_s, part = 0.0f;
      const double tilted_s = glm::dot(tilted.origin - center, tilted_normal) / glm::dot(ray, tilted_normal);
      const glm::dvec3 d = center + tilted_s * ray - tilted.origin;
      const double u = glm::dot(d, tilted.edge_s), v = glm::dot(d, tilted.edge_t);
      if (tilted_s > 0.0 && tilted_s < best && u >= 0.0 && u <= 1.0 && v >= 0.0 && v <= 1.0) part = 1.0f;
      parts.at<cv::Vec3f>(y, x) = cv::Vec3f(part, part, part);
    }
  }
  const auto mixed = [&](bool exact_occluders, int* valid_above) {
    ResamplerOptions options;
    options.exact_occluder_test = exact_occluders;
    auto resampler = Make(scene, {camera}, {}, options);
    EXPECT_NE(resampler, nullptr);
    if (resampler == nullptr) return -1;
    auto rgba = resampler->ResampleCamera(0, parts);
    EXPECT_TRUE(rgba.ok()) << rgba.status();
    int count = 0;
    *valid_above = 0;
    for (int y = 0; y < 512; ++y) {
      for (int x = 0; x < 512; ++x) {
        const auto point = scene.TexelPoint(x, y);
        // Above the ground, away from the quad's own edges (silhouettes
        // against the ground behind it, another matter: edge_margin_pixels).
        if (!point.has_value() || point->first != 1 || !(point->second.z > 0.0) || !Valid(*rgba, x, y)) continue;
        if (std::abs(point->second.x) > 0.45 || point->second.z > 0.8 * top) continue;
        ++*valid_above;
        count += rgba->at<cv::Vec4f>(y, x)[0] < 0.999f ? 1 : 0;
      }
    }
    return count;
  };
  int valid_exact = 0, valid_depth_map = 0;
  const int mixed_exact = mixed(true, &valid_exact);
  const int mixed_depth_map = mixed(false, &valid_depth_map);
  std::printf("texels of the quad above the ground: valid %d, mixed %d (exact); valid %d, mixed %d (depth map)\n",
              valid_exact, mixed_exact, valid_depth_map, mixed_depth_map);
  EXPECT_GT(valid_exact, 10000);  // measured 16899 (and 294 of as many mixed with the depth map alone)
  EXPECT_GT(valid_exact, valid_depth_map * 95 / 100);  // the band it refuses is thin
  EXPECT_EQ(mixed_exact, 0);
  EXPECT_GT(mixed_depth_map, 100);
}

// Issue #14: MarkUnreliable. With an edge margin, the plane's texels seen
// within the margin of the floating square's silhouette (a depth
// discontinuity) are refused and counted; those well away stay valid. With a
// gradient limit, pixels on a step of the image are marked, flat ones not.
TEST_F(ResamplerTest, UnreliablePixelsNearEdgesAndOnSteepGradientsAreRefused) {
  const QuadScene scene = MakeQuadScene({GroundQuad(0.02, 0.66), SquareQuad(0.3, 1.0, 0.70, 0.98)}, 512);
  const scene::CameraModel camera = LookAtCamera({0.5, -0.4, 3.0}, {0.0, 0.0, 0.0}, 640, 480, 450.0);
  const glm::dvec3 center = camera.CenterInWorld();
  constexpr double kMargin = 3.0;
  ResamplerOptions options;
  options.edge_margin_pixels = kMargin;
  auto resampler = Make(scene, {camera}, {}, options);
  ASSERT_NE(resampler, nullptr);
  cv::Mat frame(camera.height, camera.width, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5));
  ASSERT_TRUE(resampler->MarkUnreliable(0, &frame).ok());
  int marked = 0;
  for (int y = 0; y < frame.rows; ++y) {
    for (int x = 0; x < frame.cols; ++x) marked += frame.at<cv::Vec3f>(y, x)[0] == kEdgePixel ? 1 : 0;
  }
  EXPECT_GT(marked, 100);
  auto rgba = resampler->ResampleCamera(0, frame);
  ASSERT_TRUE(rgba.ok()) << rgba.status();
  int near_valid = 0, near = 0, far_invalid = 0, far = 0;
  for (int y = 0; y < 512; ++y) {
    for (int x = 0; x < 512; ++x) {
      const auto point = scene.TexelPoint(x, y);
      if (!point.has_value() || point->first != 0) continue;  // the plane only
      const std::optional<glm::dvec3> cross = CrossPlaneZ(point->second, center, 1.0);
      const double inside = InsideSquare(*cross, glm::dvec2(0.0), 0.3);
      if (inside > 0.0) continue;  // hidden
      const double distance_px = std::abs(inside) * camera.fx / camera.CamFromWorld(*cross).z;
      if (distance_px < kMargin - 1.0) {
        ++near;
        near_valid += Valid(*rgba, x, y) ? 1 : 0;
      } else if (distance_px > kMargin + 3.0 && std::abs(point->second.x) < 0.8 && std::abs(point->second.y) < 0.8) {
        ++far;  // (away from the plane's own silhouette too)
        far_invalid += Valid(*rgba, x, y) ? 0 : 1;
      }
    }
  }
  EXPECT_GT(near, 500);
  EXPECT_EQ(near_valid, 0);
  EXPECT_GT(far, 20000);
  EXPECT_EQ(far_invalid, 0);
  EXPECT_GT(resampler->Refused(0).edge, static_cast<uint64_t>(near));
  EXPECT_EQ(resampler->Refused(0).gradient, 0u);
  EXPECT_GT(resampler->Refused(0).kept, static_cast<uint64_t>(far));

  // A step of the image (0.2 | 0.6) at column 320: relative gradient 0.2 /
  // ~0.4 = 0.5 next to it, 0 elsewhere.
  ResamplerOptions gradient;
  gradient.gradient_rejection = 0.25;
  auto second = Make(scene, {camera}, {}, gradient);
  ASSERT_NE(second, nullptr);
  cv::Mat step(camera.height, camera.width, CV_32FC3, cv::Scalar(0.2, 0.2, 0.2));
  step.colRange(320, camera.width).setTo(cv::Scalar(0.6, 0.6, 0.6));
  ASSERT_TRUE(second->MarkUnreliable(0, &step).ok());
  for (int x = 300; x < 340; ++x) {
    const bool on_step = x == 319 || x == 320;
    EXPECT_EQ(step.at<cv::Vec3f>(240, x)[0] == kGradientPixel, on_step) << x;
  }
  // Units do not matter: the same image x 1000.
  cv::Mat scaled(camera.height, camera.width, CV_32FC3, cv::Scalar(200, 200, 200));
  scaled.colRange(320, camera.width).setTo(cv::Scalar(600, 600, 600));
  ASSERT_TRUE(second->MarkUnreliable(0, &scaled).ok());
  EXPECT_EQ(cv::countNonZero(scaled.reshape(1) < 0.0f), cv::countNonZero(step.reshape(1) < 0.0f));
}

TEST_F(ResamplerTest, GeometryAtlasFollowsThePose) {
  Quad tilted = SquareQuad(0.3, 0.5, 0.70, 0.98);
  tilted.edge_t = {0.0, 0.4, 0.35};  // not axis-aligned
  const QuadScene scene = MakeQuadScene({GroundQuad(0.02, 0.66), tilted}, 256);
  auto resampler = Make(scene, {});
  ASSERT_NE(resampler, nullptr);
  const glm::dmat4 identity(1.0);
  const glm::dmat4 moved =
      glm::rotate(glm::translate(identity, glm::dvec3(0.2, -0.1, 0.4)), glm::radians(30.0), glm::dvec3(1.0, 0.2, 0.0));
  for (const glm::dmat4& world_from_rest : {identity, moved}) {
    ASSERT_TRUE(resampler->SetFrame(testing::Transformed(scene, world_from_rest)).ok());
    auto geometry = resampler->Geometry();
    ASSERT_TRUE(geometry.ok()) << geometry.status();
    ASSERT_EQ(geometry->position.type(), CV_32FC4);
    ASSERT_EQ(geometry->normal.type(), CV_32FC4);
    double max_position_error = 0.0, max_normal_error = 0.0;
    int coverage_mismatch = 0;
    for (int y = 0; y < 256; ++y) {
      for (int x = 0; x < 256; ++x) {
        const cv::Vec4f& p = geometry->position.at<cv::Vec4f>(y, x);
        const cv::Vec4f& n = geometry->normal.at<cv::Vec4f>(y, x);
        const auto point = scene.TexelPoint(x, y);
        if (!point.has_value()) {
          coverage_mismatch += p[3] != 0.0f || n[3] != 0.0f;
          continue;
        }
        if (p[3] != 1.0f || n[3] != 1.0f) {
          ++coverage_mismatch;
          continue;
        }
        const glm::dvec3 expected_p(world_from_rest * glm::dvec4(point->second, 1.0));
        const glm::dvec3 expected_n = glm::normalize(glm::dmat3(world_from_rest) * scene.quads[point->first].Normal());
        max_position_error = std::max(max_position_error, glm::length(glm::dvec3(p[0], p[1], p[2]) - expected_p));
        max_normal_error = std::max(max_normal_error, glm::length(glm::dvec3(n[0], n[1], n[2]) - expected_n));
      }
    }
    EXPECT_EQ(coverage_mismatch, 0);
    EXPECT_LT(max_position_error, kPositionTolerance);
    EXPECT_LT(max_normal_error, kNormalTolerance);
  }
}

scene::Light PointLight(const glm::vec3& position) {
  scene::Light light;
  light.position = position;
  return light;
}

TEST_F(ResamplerTest, ShadowAtlasHasOneBitPerLight) {
  constexpr double kOccluderHalf = 0.25, kOccluderHeight = 1.0;
  const QuadScene scene =
      MakeQuadScene({GroundQuad(0.02, 0.66), SquareQuad(kOccluderHalf, kOccluderHeight, 0.70, 0.98)}, 256);
  scene::Light directional;
  directional.directional = true;
  directional.direction = glm::normalize(glm::vec3(0.3f, -0.2f, 1.0f));
  const std::vector<scene::Light> lights = {PointLight({0.0f, 0.0f, 2.0f}), PointLight({0.7f, 0.4f, 2.5f}),
                                            directional};
  ResamplerOptions options;
  options.shadow_map_size = 512;
  auto resampler = Make(scene, {}, lights, options);
  ASSERT_NE(resampler, nullptr);

  // The scene translated by `offset` (lights fixed): bit k of a plane texel is
  // clear exactly where the segment to light k crosses the occluder.
  auto check = [&](const glm::dvec3& offset) {
    ASSERT_TRUE(resampler->SetFrame(testing::Transformed(scene, glm::translate(glm::dmat4(1.0), offset))).ok());
    auto visible = resampler->ShadowAtlas();
    ASSERT_TRUE(visible.ok()) << visible.status();
    ASSERT_EQ(visible->type(), CV_16UC1);
    int shadowed[3] = {0, 0, 0}, lit[3] = {0, 0, 0}, wrong[3] = {0, 0, 0}, wrong_occluder = 0, wrong_uncovered = 0;
    for (int y = 0; y < 256; ++y) {
      for (int x = 0; x < 256; ++x) {
        const uint16_t bits = visible->at<uint16_t>(y, x);
        const auto point = scene.TexelPoint(x, y);
        if (!point.has_value()) {
          wrong_uncovered += bits != 0;
          continue;
        }
        if (point->first == 1) {
          wrong_occluder += bits != 0x7;  // the occluder's top sees every light
          continue;
        }
        EXPECT_EQ(bits & ~0x7, 0);
        const glm::dvec3 p = point->second + offset;
        for (int k = 0; k < 3; ++k) {
          const glm::dvec3 towards =
              lights[k].directional ? p + 10.0 * glm::dvec3(lights[k].direction) : glm::dvec3(lights[k].position);
          const std::optional<glm::dvec3> cross = CrossPlaneZ(p, towards, kOccluderHeight + offset.z);
          const double inside = cross.has_value() ? InsideSquare(*cross, glm::dvec2(offset), kOccluderHalf) : -1.0;
          if (std::abs(inside) < kShadowBandWorld) continue;
          const bool blocked = inside > 0.0;
          (blocked ? shadowed : lit)[k]++;
          if (((bits >> k) & 1) == (blocked ? 1 : 0)) ++wrong[k];
        }
      }
    }
    for (int k = 0; k < 3; ++k) {
      SCOPED_TRACE(::testing::Message() << "light " << k);
      EXPECT_GT(shadowed[k], 1000);
      EXPECT_GT(lit[k], 10000);
      EXPECT_EQ(wrong[k], 0);
    }
    EXPECT_EQ(wrong_occluder, 0);
    EXPECT_EQ(wrong_uncovered, 0);
    // Computed once per frame: a second call returns the same atlas.
    auto again = resampler->ShadowAtlas();
    ASSERT_TRUE(again.ok());
    EXPECT_EQ(cv::countNonZero(*again != *visible), 0);
  };
  check(glm::dvec3(0.0));
  check(glm::dvec3(0.3, -0.2, 0.1));
}

// More than 16 lights: light k is bit k % 16 of channel k / 16, each exact
// against the segment-to-light test; lights not asked for are 0 and the
// asked-for ones are the same as in the full atlas.
TEST_F(ResamplerTest, ShadowAtlasOfFortyLightsHasOneBitPerLightInChannels) {
  constexpr double kOccluderHalf = 0.25, kOccluderHeight = 1.0;
  constexpr int kLights = 40;
  const QuadScene scene =
      MakeQuadScene({GroundQuad(0.02, 0.66), SquareQuad(kOccluderHalf, kOccluderHeight, 0.70, 0.98)}, 256);
  std::vector<scene::Light> lights;
  for (int k = 0; k < kLights; ++k) {
    const float azimuth = 2.399963f * static_cast<float>(k);
    const float r = 0.1f + 0.5f * static_cast<float>(k % 5) / 4.0f;
    if (k % 3 == 2) {
      scene::Light directional;
      directional.directional = true;
      directional.direction = glm::normalize(glm::vec3(r * std::cos(azimuth), r * std::sin(azimuth), 1.0f));
      lights.push_back(directional);
    } else {
      lights.push_back(PointLight({r * std::cos(azimuth), r * std::sin(azimuth), 2.0f + 0.25f * (k % 4)}));
    }
  }
  ResamplerOptions options;
  options.shadow_map_size = 512;
  auto resampler = Make(scene, {}, lights, options);
  ASSERT_NE(resampler, nullptr);
  auto visible = resampler->ShadowAtlas();
  ASSERT_TRUE(visible.ok()) << visible.status();
  ASSERT_EQ(visible->type(), CV_16UC3);
  auto bit = [](const cv::Mat& atlas, int y, int x, int k) {
    return (atlas.ptr<uint16_t>(y)[3 * x + k / 16] >> (k % 16)) & 1;
  };
  std::vector<int> shadowed(kLights, 0), lit(kLights, 0), wrong(kLights, 0);
  int wrong_occluder = 0, wrong_uncovered = 0, unused_bits = 0;
  for (int y = 0; y < 256; ++y) {
    for (int x = 0; x < 256; ++x) {
      const uint16_t* bits = visible->ptr<uint16_t>(y) + 3 * x;
      unused_bits += (bits[2] & 0xff00) != 0;  // lights 40..47 do not exist
      const auto point = scene.TexelPoint(x, y);
      if (!point.has_value()) {
        wrong_uncovered += (bits[0] | bits[1] | bits[2]) != 0;
        continue;
      }
      if (point->first == 1) {
        wrong_occluder += bits[0] != 0xffff || bits[1] != 0xffff || bits[2] != 0xff;
        continue;
      }
      for (int k = 0; k < kLights; ++k) {
        const glm::dvec3 p = point->second;
        const glm::dvec3 towards =
            lights[k].directional ? p + 10.0 * glm::dvec3(lights[k].direction) : glm::dvec3(lights[k].position);
        const std::optional<glm::dvec3> cross = CrossPlaneZ(p, towards, kOccluderHeight);
        const double inside = cross.has_value() ? InsideSquare(*cross, glm::dvec2(0.0), kOccluderHalf) : -1.0;
        if (std::abs(inside) < kShadowBandWorld) continue;
        const bool blocked = inside > 0.0;
        (blocked ? shadowed : lit)[k]++;
        if (bit(*visible, y, x, k) == (blocked ? 1 : 0)) ++wrong[k];
      }
    }
  }
  for (int k = 0; k < kLights; ++k) {
    SCOPED_TRACE(::testing::Message() << "light " << k);
    EXPECT_GT(shadowed[k], 1000);
    EXPECT_GT(lit[k], 10000);
    EXPECT_EQ(wrong[k], 0);
  }
  EXPECT_EQ(wrong_occluder, 0);
  EXPECT_EQ(wrong_uncovered, 0);
  EXPECT_EQ(unused_bits, 0);

  // Only lights 3, 17 and 39 asked for (as for a frame lit by those).
  std::vector<bool> needed(kLights, false);
  needed[3] = needed[17] = needed[39] = true;
  auto some = resampler->ShadowAtlas(needed);
  ASSERT_TRUE(some.ok()) << some.status();
  ASSERT_EQ(some->type(), CV_16UC3);
  int differs = 0, extra = 0, set = 0;
  for (int y = 0; y < 256; ++y) {
    for (int x = 0; x < 256; ++x) {
      for (int k = 0; k < kLights; ++k) {
        const int b = bit(*some, y, x, k);
        if (needed[k]) {
          differs += b != bit(*visible, y, x, k);
          set += b;
        } else {
          extra += b;
        }
      }
    }
  }
  EXPECT_EQ(differs, 0);
  EXPECT_EQ(extra, 0);
  EXPECT_GT(set, 3 * 10000);
  EXPECT_TRUE(absl::IsInvalidArgument(resampler->ShadowAtlas(std::vector<bool>(3, true)).status()));
  // At most 16 lights: one channel, as before.
  auto sixteen = Make(scene, {}, std::vector<scene::Light>(lights.begin(), lights.begin() + 16), options);
  ASSERT_NE(sixteen, nullptr);
  auto one_channel = sixteen->ShadowAtlas();
  ASSERT_TRUE(one_channel.ok()) << one_channel.status();
  EXPECT_EQ(one_channel->type(), CV_16UC1);
}

// No fixed clip planes or absolute tolerances: the scene, camera translation
// and light positions scaled by 1000 resample the same atlas and shadows.
TEST_F(ResamplerTest, WorldScaledBy1000ResamplesTheSameAtlas) {
  const QuadScene scene = MakeQuadScene({GroundQuad(0.02, 0.66), SquareQuad(0.25, 1.0, 0.70, 0.98)}, 256);
  scene::Light directional;
  directional.directional = true;
  directional.direction = glm::normalize(glm::vec3(0.3f, -0.2f, 1.0f));
  ResamplerOptions options;
  options.shadow_map_size = 512;
  auto run = [&](double s, cv::Mat* rgba, cv::Mat* shadows) {
    const scene::CameraModel camera = LookAtCamera(s * glm::dvec3(0.4, -2.5, 3.0), {0, 0, 0}, 320, 240, 300.0);
    auto resampler =
        Make(scene, {camera}, {PointLight(static_cast<float>(s) * glm::vec3(0.7f, 0.4f, 2.5f)), directional}, options);
    ASSERT_NE(resampler, nullptr);
    ASSERT_TRUE(resampler->SetFrame(testing::Transformed(scene, glm::scale(glm::dmat4(1.0), glm::dvec3(s)))).ok());
    auto resampled = resampler->ResampleCamera(0, PixelPositionFrame(camera.width, camera.height));
    ASSERT_TRUE(resampled.ok()) << resampled.status();
    *rgba = *resampled;
    auto visible = resampler->ShadowAtlas();
    ASSERT_TRUE(visible.ok()) << visible.status();
    *shadows = *visible;
  };
  cv::Mat rgba1, shadows1, rgba1000, shadows1000;
  run(1.0, &rgba1, &shadows1);
  run(1000.0, &rgba1000, &shadows1000);
  ASSERT_FALSE(rgba1.empty());
  ASSERT_FALSE(rgba1000.empty());
  int valid = 0, validity_differs = 0, far_off = 0, lit = 0;
  for (int y = 0; y < 256; ++y) {
    for (int x = 0; x < 256; ++x) {
      valid += Valid(rgba1, x, y);
      validity_differs += Valid(rgba1, x, y) != Valid(rgba1000, x, y);
      if (Valid(rgba1, x, y) && Valid(rgba1000, x, y)) {
        const cv::Vec4f a = rgba1.at<cv::Vec4f>(y, x), b = rgba1000.at<cv::Vec4f>(y, x);
        far_off += std::abs(a[0] - b[0]) * 320 > 0.01 || std::abs(a[1] - b[1]) * 240 > 0.01;  // pixels
      }
      lit += shadows1.at<uint16_t>(y, x) == 0x3;
    }
  }
  EXPECT_GT(valid, 20000);
  EXPECT_LE(validity_differs, valid / 1000);  // boundary texels where float rounding decides
  EXPECT_EQ(far_off, 0);
  EXPECT_GT(lit, 20000);
  EXPECT_LE(cv::countNonZero(shadows1 != shadows1000), 64);
}

// Spot (a closed, curved mesh with its own UVs and seams): a camera's
// visibility and the shadow atlas of a point light at the camera's centre
// are the same question asked by two different passes, so they must agree up
// to the grazing margin, the image bounds and boundary texels.
TEST_F(ResamplerTest, CameraVisibilityAgreesWithShadowOfALightAtTheCamera) {
  const std::string path = std::string(MVBRDF_SHARED_DATA_DIR) + "/spot/spot_triangulated.obj";
  auto mesh = scene::LoadMesh(path, "spot");
  if (!mesh.ok() && mesh.status().code() == absl::StatusCode::kNotFound) GTEST_SKIP() << mesh.status();
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  atlas::Atlas atlas;
  atlas.size = 512;
  atlas.topology = mesh->topology;
  atlas::RasterizeTriangles(&atlas);
  const glm::dvec3 eye(1.6, 1.2, 2.2);
  const scene::CameraModel camera = LookAtCamera(eye, {0.0, 0.1, 0.2}, 640, 480, 500.0);
  ResamplerOptions options;
  options.shadow_map_size = 1024;
  auto resampler = Resampler::Create(*context_, atlas, {camera}, {PointLight(glm::vec3(eye))}, options);
  ASSERT_TRUE(resampler.ok()) << resampler.status();
  ASSERT_TRUE((*resampler)->SetFrame(mesh->positions).ok());
  auto rgba = (*resampler)->ResampleCamera(0, PixelPositionFrame(camera.width, camera.height));
  ASSERT_TRUE(rgba.ok()) << rgba.status();
  auto lit = (*resampler)->ShadowAtlas();
  ASSERT_TRUE(lit.ok()) << lit.status();
  auto geometry = (*resampler)->Geometry();
  ASSERT_TRUE(geometry.ok()) << geometry.status();
  const double min_cos = std::sin(glm::radians(options.grazing_margin_deg));
  int covered = 0, valid = 0, valid_not_lit = 0, facing_lit = 0, facing_lit_not_valid = 0, off_position = 0;
  double max_error = 0.0;
  for (int y = 0; y < atlas.size; ++y) {
    for (int x = 0; x < atlas.size; ++x) {
      const cv::Vec4f& p = geometry->position.at<cv::Vec4f>(y, x);
      if (p[3] < 0.5f) continue;
      ++covered;
      const glm::dvec3 point(p[0], p[1], p[2]);
      const cv::Vec4f& n = geometry->normal.at<cv::Vec4f>(y, x);
      const bool is_valid = Valid(*rgba, x, y), is_lit = lit->at<uint16_t>(y, x) & 1;
      if (is_valid) {
        ++valid;
        valid_not_lit += is_lit ? 0 : 1;
        const cv::Vec4f& s = rgba->at<cv::Vec4f>(y, x);
        const double error =
            glm::length(glm::dvec2(s[0] * camera.width, s[1] * camera.height) - camera.Project(point));
        max_error = std::max(max_error, error);
        off_position += error > kPixelTolerance ? 1 : 0;
      }
      // Facing the camera with some room beyond the margin (the margin's own
      // boundary is float rounding).
      const double cos_view = glm::dot(glm::dvec3(n[0], n[1], n[2]), glm::normalize(eye - point));
      if (is_lit && cos_view > min_cos + 0.02) {
        ++facing_lit;
        facing_lit_not_valid += is_valid ? 0 : 1;
      }
    }
  }
  EXPECT_GT(covered, 50000);
  EXPECT_GT(valid, covered / 5);
  // Samples move only at silhouettes (background pixels dropped from the
  // footprint), by less than a pixel. Measured: 1649 of 67346 valid texels
  // (2.4%) are off their pinhole position by more than kPixelTolerance.
  EXPECT_LT(max_error, kSilhouetteBandPixels);
  EXPECT_LT(off_position, valid / 20) << off_position << " of " << valid;
  // Disagreement only at boundaries (silhouettes, occlusion edges: about one
  // camera pixel or shadow-map texel wide). Measured with the depth map
  // alone: 28 of 67685 valid texels not lit, 451 of 67089 lit and facing
  // texels not valid; with the exact occluder test 0 and 557 (it refuses
  // texels at occluders' edges that the biased shadow map calls lit; against
  // the generator's truth on a Spot sequence its false-valid fraction is half
  // the depth map's, recall the same).
  EXPECT_LT(valid_not_lit, valid / 100);
  EXPECT_LT(facing_lit_not_valid, facing_lit / 100);
  std::printf("valid %d, valid not lit %d; facing lit %d, not valid %d\n", valid, valid_not_lit, facing_lit,
              facing_lit_not_valid);
}

TEST_F(ResamplerTest, RejectsBadInput) {
  const QuadScene scene = MakeQuadScene({GroundQuad(0.05, 0.95)}, 64);
  const scene::CameraModel camera = LookAtCamera({0.4, -0.5, 3.0}, {0.0, 0.0, 0.0}, 64, 48, 50.0);
  ResamplerOptions bad;
  bad.grazing_margin_deg = 95.0;
  EXPECT_FALSE(Resampler::Create(*context_, scene.atlas, {camera}, {}, bad).ok());
  scene::CameraModel no_focal = camera;
  no_focal.fx = 0.0;
  EXPECT_FALSE(Resampler::Create(*context_, scene.atlas, {no_focal}, {}, {}).ok());
  auto resampler = Resampler::Create(*context_, scene.atlas, {camera}, {}, {});
  ASSERT_TRUE(resampler.ok()) << resampler.status();
  const cv::Mat frame(48, 64, CV_32FC3, cv::Scalar(0, 0, 0));
  EXPECT_EQ((*resampler)->ResampleCamera(0, frame).status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_FALSE((*resampler)->SetFrame({glm::vec3(0.0f)}).ok());  // wrong vertex count
  ASSERT_TRUE((*resampler)->SetFrame(scene.positions).ok());
  EXPECT_FALSE((*resampler)->ResampleCamera(1, frame).ok());
  EXPECT_FALSE((*resampler)->ResampleCamera(0, cv::Mat(48, 64, CV_8UC3)).ok());
  EXPECT_FALSE((*resampler)->ResampleCamera(0, cv::Mat(40, 64, CV_32FC3)).ok());
  EXPECT_TRUE((*resampler)->ResampleCamera(0, frame).ok());
}

// ---------------------------------------------------------------------------
// Benchmark (disabled; run with
//   LP_NUM_THREADS=2 build-resample/core/resample/resample_test
//     --gtest_also_run_disabled_tests --gtest_filter='*Benchmark*')

// A UV sphere of `rings` x `segments` quads between latitudes +-85 degrees
// (no degenerate pole triangles), with a UV seam (render vertices split,
// file vertices shared) and UVs filling [0.01, 0.99]^2.
atlas::Atlas SphereAtlas(int rings, int segments, int size, scene::FramePositions* positions) {
  atlas::Atlas atlas;
  scene::MeshTopology& topo = atlas.topology;
  const double max_lat = glm::radians(85.0);
  for (int r = 0; r <= rings; ++r) {
    const double lat = -max_lat + 2.0 * max_lat * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double lon = 2.0 * glm::pi<double>() * s / segments;
      positions->push_back(glm::vec3(std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat)));
    }
  }
  topo.num_file_vertices = static_cast<uint32_t>(positions->size());
  for (int r = 0; r <= rings; ++r) {
    for (int s = 0; s <= segments; ++s) {
      topo.render_to_file_vertex.push_back(static_cast<uint32_t>(r * segments + s % segments));
      topo.uvs.emplace_back(0.01f + 0.98f * s / segments, 0.01f + 0.98f * r / rings);
    }
  }
  for (int r = 0; r < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      const uint32_t a = r * (segments + 1) + s, b = a + 1, c = a + (segments + 1), d = c + 1;
      topo.triangles.emplace_back(a, b, d);
      topo.triangles.emplace_back(a, d, c);
    }
  }
  for (const glm::uvec3& t : topo.triangles) {
    topo.file_triangles.emplace_back(topo.render_to_file_vertex[t.x], topo.render_to_file_vertex[t.y],
                                     topo.render_to_file_vertex[t.z]);
  }
  atlas.size = size;
  atlas::RasterizeTriangles(&atlas);
  return atlas;
}

double MedianMs(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

template <typename F>
double TimeMs(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// The shadow maps are cleared and drawn only where the frame's bounding
// sphere projects (render::ShadowMaps::Render): a frame's shadow atlas is
// the same after frames elsewhere, larger and smaller, left other texels of
// the maps as it is from a resampler that never drew before. A sphere mesh
// reaches its bounding sphere's outline in every light's view, so its
// terminator is looked up at the rectangle's edges.
TEST_F(ResamplerTest, ShadowAtlasDoesNotDependOnTheFramesBefore) {
  scene::FramePositions positions;
  const atlas::Atlas atlas = SphereAtlas(24, 32, 128, &positions);
  const scene::CameraModel camera = LookAtCamera({0.0, -3.0, 0.5}, {0.0, 0.0, 0.0}, 160, 120, 100.0);
  const std::vector<scene::Light> lights = {PointLight({0.0f, 0.0f, 2.0f}), PointLight({1.6f, 0.4f, -0.5f}),
                                            PointLight({-1.2f, -1.1f, 0.3f})};
  ResamplerOptions options;
  options.shadow_map_size = 256;
  auto warm = Resampler::Create(*context_, atlas, {camera}, lights, options);
  auto fresh = Resampler::Create(*context_, atlas, {camera}, lights, options);
  ASSERT_TRUE(warm.ok() && fresh.ok());
  const auto posed = [&](float scale, const glm::vec3& offset) {
    scene::FramePositions p = positions;
    for (glm::vec3& v : p) v = v * scale + offset;
    return p;
  };
  for (const auto& [scale, offset] : {std::pair{1.4f, glm::vec3(-0.3f, 0.2f, -0.2f)},
                                      std::pair{0.4f, glm::vec3(0.4f, 0.1f, 0.5f)},
                                      std::pair{0.9f, glm::vec3(0.0f, 0.0f, 0.6f)}}) {
    ASSERT_TRUE((*warm)->SetFrame(posed(scale, offset)).ok());
    ASSERT_TRUE((*warm)->ShadowAtlas().ok());
  }
  const scene::FramePositions last = posed(0.8f, glm::vec3(0.1f, -0.05f, 0.0f));
  ASSERT_TRUE((*warm)->SetFrame(last).ok());
  ASSERT_TRUE((*fresh)->SetFrame(last).ok());
  auto a = (*warm)->ShadowAtlas();
  auto b = (*fresh)->ShadowAtlas();
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(cv::countNonZero(*a != *b), 0);
  // Each light lights some texels and not others: the comparison sees the maps.
  for (int k = 0; k < 3; ++k) {
    int on = 0;
    for (int y = 0; y < a->rows; ++y) {
      for (int x = 0; x < a->cols; ++x) on += (a->at<uint16_t>(y, x) >> k) & 1;
    }
    EXPECT_GT(on, 100) << "light " << k;
    EXPECT_LT(on, atlas.size * atlas.size) << "light " << k;
  }
}

TEST_F(ResamplerTest, DISABLED_Benchmark) {
  constexpr int kRepeats = 15;
  scene::FramePositions positions;
  const int sizes[2] = {512, 1024};
  // 100 x 100 quads: 20 000 triangles.
  const scene::CameraModel camera = LookAtCamera({0.0, -3.0, 0.5}, {0.0, 0.0, 0.0}, 320, 240, 200.0);
  const cv::Mat frame = PixelPositionFrame(camera.width, camera.height);
  std::vector<scene::Light> lights;
  for (int i = -1; i <= 1; ++i) {
    for (int j = -1; j <= 1; ++j) lights.push_back(PointLight({1.5f * i, 1.5f * j, 3.0f}));
  }
  for (int size : sizes) {
    positions.clear();
    const atlas::Atlas atlas = SphereAtlas(100, 100, size, &positions);
    for (int shadow_size : {256, 1024}) {
      ResamplerOptions options;
      options.shadow_map_size = shadow_size;
      auto resampler = Resampler::Create(*context_, atlas, {camera}, lights, options);
      ASSERT_TRUE(resampler.ok()) << resampler.status();
      Resampler& r = **resampler;
      std::vector<double> set_frame, first_camera, camera_pass, geometry, shadow;
      for (int i = 0; i < kRepeats; ++i) {
        // A slightly different pose each time (nothing is cached across frames).
        scene::FramePositions pose = positions;
        for (glm::vec3& p : pose) p *= 1.0f + 0.001f * i;
        set_frame.push_back(TimeMs([&] {
          ASSERT_TRUE(r.SetFrame(pose).ok());
          glFinish();  // SetFrame only queues the draw
        }));
        first_camera.push_back(TimeMs([&] { ASSERT_TRUE(r.ResampleCamera(0, frame).ok()); }));
        camera_pass.push_back(TimeMs([&] { ASSERT_TRUE(r.ResampleCamera(0, frame).ok()); }));
        geometry.push_back(TimeMs([&] { ASSERT_TRUE(r.Geometry().ok()); }));
        shadow.push_back(TimeMs([&] { ASSERT_TRUE(r.ShadowAtlas().ok()); }));
      }
      std::printf(
          "atlas %4d, %zu triangles, camera %dx%d, %zu point lights, shadow maps %4d: SetFrame %.1f ms, "
          "ResampleCamera first of frame (with depth map) %.1f ms, again %.1f ms, Geometry %.1f ms, "
          "ShadowAtlas %.1f ms (medians of %d)\n",
          size, atlas.topology.triangles.size(), camera.width, camera.height, lights.size(), shadow_size,
          MedianMs(set_frame), MedianMs(first_camera), MedianMs(camera_pass), MedianMs(geometry), MedianMs(shadow),
          kRepeats);
    }
  }
}

}  // namespace
}  // namespace mvbrdf::resample
