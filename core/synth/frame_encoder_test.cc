#include "core/synth/frame_encoder.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "core/scene/video_source.h"

namespace mvbrdf::synth {
namespace {

TEST(FrameEncoderTest, EncodesSrgbAndClipsWithoutNoise) {
  cv::Mat img(1, 4, CV_32FC3);
  img.at<cv::Vec3f>(0, 0) = {0.0f, 0.5f, 1.0f};
  img.at<cv::Vec3f>(0, 1) = {2.0f, -1.0f, 0.0031308f};
  img.at<cv::Vec3f>(0, 2) = {0.21586f, 0.21586f, 0.21586f};
  img.at<cv::Vec3f>(0, 3) = {0.25f, 0.25f, 0.25f};
  std::mt19937 rng(1);
  const cv::Mat out = EncodeSrgb8(img, {}, rng);
  ASSERT_EQ(out.type(), CV_8UC3);
  // BGR order out.
  EXPECT_EQ(out.at<cv::Vec3b>(0, 0), cv::Vec3b(255, 188, 0));
  EXPECT_EQ(out.at<cv::Vec3b>(0, 1), cv::Vec3b(10, 0, 255));  // 0.0031308 -> 0.04045*255
  EXPECT_EQ(out.at<cv::Vec3b>(0, 2), cv::Vec3b(128, 128, 128));
  // Exposure 2 doubles the linear value before encoding: 0.25 -> 0.5 -> 188.
  EncodeOptions bright;
  bright.exposure = 2.0;
  EXPECT_EQ(EncodeSrgb8(img, bright, rng).at<cv::Vec3b>(0, 3), cv::Vec3b(188, 188, 188));
}

TEST(FrameEncoderTest, NoiseHasTheRequestedSigma) {
  cv::Mat img(200, 200, CV_32FC3, cv::Scalar::all(0.21586));  // code value 128
  EncodeOptions options;
  options.noise_sigma = 2.0;
  std::mt19937 rng(3);
  const cv::Mat out = EncodeSrgb8(img, options, rng);
  cv::Scalar mean, stddev;
  cv::meanStdDev(out.reshape(1), mean, stddev);
  EXPECT_NEAR(mean[0], 128.0, 0.05);
  EXPECT_NEAR(stddev[0], 2.0, 0.1);  // rounding adds 1/12 to the variance
}

// 16 bits per channel: the same sRGB curve at 65535 code values, so a dark
// value (a glossy material exposed for its highlights) keeps it to ~0.1 %
// instead of 8 bits' ~5-20 %; noise of sigma 2 8-bit code values is 514.
TEST(FrameEncoderTest, SixteenBitsKeepDarkValues) {
  cv::Mat img(1, 2, CV_32FC3);
  img.at<cv::Vec3f>(0, 0) = {0.002f, 0.0005f, 1.0f};
  img.at<cv::Vec3f>(0, 1) = {0.21586f, 0.21586f, 0.21586f};
  std::mt19937 rng(1);
  const cv::Mat out = EncodeSrgb(img, {}, 16, rng);
  ASSERT_EQ(out.type(), CV_16UC3);
  const cv::Vec<uint16_t, 3> dark = out.at<cv::Vec<uint16_t, 3>>(0, 0);
  EXPECT_EQ(dark[0], 65535);  // BGR: blue is 1.0
  EXPECT_NEAR(scene::SrgbToLinear(dark[2] / 65535.0f), 0.002f, 0.002f * 1e-3f);
  EXPECT_NEAR(scene::SrgbToLinear(dark[1] / 65535.0f), 0.0005f, 0.0005f * 2e-3f);
  const double mid = out.at<cv::Vec<uint16_t, 3>>(0, 1)[0];
  EXPECT_NEAR(mid, 128.0 * 257.0, 257.0);
  EXPECT_EQ(EncodeSrgb(img, {}, 8, rng).type(), CV_8UC3);
  cv::Mat grey(200, 200, CV_32FC3, cv::Scalar::all(0.21586));
  EncodeOptions options;
  options.noise_sigma = 2.0;
  cv::Scalar mean, stddev;
  cv::meanStdDev(EncodeSrgb(grey, options, 16, rng).reshape(1), mean, stddev);
  EXPECT_NEAR(stddev[0], 2.0 * 257.0, 0.1 * 257.0);
}

// A width x height pinhole camera with focal length f, principal point at
// the image centre, at the world origin looking down +z.
scene::CameraModel CentredCamera(int width, int height, double f) {
  scene::CameraModel cam;
  cam.width = width;
  cam.height = height;
  cam.fx = cam.fy = f;
  cam.cx = 0.5 * (width - 1);
  cam.cy = 0.5 * (height - 1);
  return cam;
}

TEST(FrameEncoderTest, DistortionMovesPixelsWhereTheCameraModelSays) {
  scene::CameraModel cam = CentredCamera(160, 120, 150.0);
  // No distortion: the same image.
  cv::Mat img(cam.height, cam.width, CV_32FC1, cv::Scalar(0));
  EXPECT_EQ(ApplyDistortion(img, cam).data, img.data);
  // A single bright pixel in the pinhole image lands where Project() puts the
  // same ray with distortion.
  cam.distortion[0] = -0.2;
  const glm::dvec3 point(0.45, 0.3, 1.0);  // camera frame == world frame
  const glm::dvec2 pinhole(cam.fx * point.x + cam.cx, cam.fy * point.y + cam.cy);
  cv::Mat spot(cam.height, cam.width, CV_32FC1, cv::Scalar(0));
  cv::circle(spot, cv::Point(static_cast<int>(std::lround(pinhole.x)), static_cast<int>(std::lround(pinhole.y))), 2,
             cv::Scalar(1.0), -1);
  const cv::Mat distorted = ApplyDistortion(spot, cam);
  cv::Point max_loc;
  cv::minMaxLoc(distorted, nullptr, nullptr, nullptr, &max_loc);
  const glm::dvec2 expected = cam.Project(point);
  EXPECT_NEAR(max_loc.x, expected.x, 1.5);
  EXPECT_NEAR(max_loc.y, expected.y, 1.5);
  EXPECT_GT(std::abs(expected.x - pinhole.x), 3.0);  // the distortion is not negligible
}

// A pinhole image at 4x the resolution, warped: each output pixel holds (up
// to a quarter pixel's bilinear blur) the value at its own ray, so a sharp
// ramp is reproduced where the camera model puts it; at 1x the same warp
// blurs it by a pixel.
TEST(FrameEncoderTest, OversampledPinholeImageWarpsLikePointSamples) {
  scene::CameraModel cam = CentredCamera(80, 60, 70.0);
  cam.distortion[0] = -0.2;
  // f(normalised x) = a steep periodic ramp in the undistorted plane: a
  // value that changes by up to ~0.6 per pixel, like a highlight's flank.
  const auto f = [](double xn, double yn) { return 0.5 + 0.5 * std::sin(80.0 * xn + 7.0 * yn); };
  const auto pinhole_image = [&](int oversampling) {
    const scene::CameraModel fine = scene::Supersampled(cam, oversampling);
    cv::Mat img(fine.height, fine.width, CV_32FC1);
    for (int y = 0; y < fine.height; ++y) {
      for (int x = 0; x < fine.width; ++x) img.at<float>(y, x) = f((x - fine.cx) / fine.fx, (y - fine.cy) / fine.fy);
    }
    return img;
  };
  const auto error_at = [&](int oversampling) {
    const cv::Mat warped = ApplyDistortion(pinhole_image(oversampling), cam, oversampling);
    EXPECT_EQ(warped.cols, cam.width);
    EXPECT_EQ(warped.rows, cam.height);
    double sum = 0.0;
    int n = 0;
    for (int y = 10; y < cam.height - 10; ++y) {  // away from the border the warp leaves black
      for (int x = 10; x < cam.width - 10; ++x) {
        const glm::dvec2 u = cam.Undistort({(x - cam.cx) / cam.fx, (y - cam.cy) / cam.fy});
        const double e = warped.at<float>(y, x) - f(u.x, u.y);
        sum += e * e;
        ++n;
      }
    }
    return std::sqrt(sum / n);
  };
  const double at1 = error_at(1), at4 = error_at(kDistortionOversampling);
  EXPECT_GT(at1, 0.02);
  EXPECT_LT(at4, 0.01);
  EXPECT_LT(at4, at1 / 8.0);  // bilinear's error falls as the square of the spacing
}

// Highlights narrower than a pixel (hair's on the studio actor at 320x240):
// the warp of a 4x pinhole image keeps their height at each pixel's ray
// where a bilinear lookup of the same image lowers it (ks and ke of such a
// lobe come out low; frame_encoder.h has the measured figures).
TEST(FrameEncoderTest, OversampledWarpKeepsSubpixelHighlights) {
  scene::CameraModel cam = CentredCamera(96, 72, 90.0);
  cam.distortion[0] = -0.05;
  // Gaussian spots of sigma 0.3 camera pixels on a grid with irrational
  // spacing, so every sub-pixel phase occurs.
  const double sigma = 0.3 / cam.fx, spacing = 4.37 / cam.fx;
  const auto f = [&](double xn, double yn) {
    const double dx = std::remainder(xn, spacing), dy = std::remainder(yn, spacing);
    return std::exp(-(dx * dx + dy * dy) / (2.0 * sigma * sigma));
  };
  const int s = kDistortionOversampling;
  const scene::CameraModel fine = scene::Supersampled(cam, s);
  cv::Mat pinhole(fine.height, fine.width, CV_32FC1);
  for (int y = 0; y < fine.height; ++y) {
    for (int x = 0; x < fine.width; ++x) pinhole.at<float>(y, x) = f((x - fine.cx) / fine.fx, (y - fine.cy) / fine.fy);
  }
  cv::Mat map_x(cam.height, cam.width, CV_32FC1), map_y(cam.height, cam.width, CV_32FC1);
  for (int y = 0; y < cam.height; ++y) {
    for (int x = 0; x < cam.width; ++x) {
      const glm::dvec2 u = cam.Undistort({(x - cam.cx) / cam.fx, (y - cam.cy) / cam.fy});
      map_x.at<float>(y, x) = static_cast<float>(fine.fx * u.x + fine.cx);
      map_y.at<float>(y, x) = static_cast<float>(fine.fy * u.y + fine.cy);
    }
  }
  cv::Mat bilinear;
  cv::remap(pinhole, bilinear, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  const cv::Mat warped = ApplyDistortion(pinhole, cam, s);
  // The summed height of the spots' peaks (pixels where the truth exceeds
  // 0.5) against the truth's.
  double truth = 0.0, ours = 0.0, linear = 0.0;
  for (int y = 4; y < cam.height - 4; ++y) {
    for (int x = 4; x < cam.width - 4; ++x) {
      const glm::dvec2 u = cam.Undistort({(x - cam.cx) / cam.fx, (y - cam.cy) / cam.fy});
      const double t = f(u.x, u.y);
      if (t < 0.5) continue;
      truth += t;
      ours += warped.at<float>(y, x);
      linear += bilinear.at<float>(y, x);
    }
  }
  ASSERT_GT(truth, 10.0);
  const double ours_error = std::abs(ours / truth - 1.0), linear_error = std::abs(linear / truth - 1.0);
  std::printf("sub-pixel peaks: bicubic %.4f, bilinear %.4f relative error\n", ours_error, linear_error);
  EXPECT_LT(ours_error, 0.02);
  EXPECT_GT(linear_error, 2.0 * ours_error);
}

}  // namespace
}  // namespace mvbrdf::synth
