#include "core/synth/frame_encoder.h"

#include <algorithm>
#include <limits>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "core/scene/video_source.h"

namespace mvbrdf::synth {

cv::Mat ApplyDistortion(const cv::Mat& undistorted, const scene::CameraModel& camera, int oversampling) {
  CV_Assert(oversampling >= 1);
  if (!camera.has_distortion() && oversampling == 1) return undistorted;
  const scene::CameraModel pinhole = scene::Supersampled(camera, oversampling);
  CV_Assert(undistorted.cols == pinhole.width && undistorted.rows == pinhole.height);
  cv::Mat map_x(camera.height, camera.width, CV_32FC1);
  cv::Mat map_y(camera.height, camera.width, CV_32FC1);
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const glm::dvec2 d((x - camera.cx) / camera.fx, (y - camera.cy) / camera.fy);
      const glm::dvec2 u = camera.Undistort(d);
      map_x.at<float>(y, x) = static_cast<float>(pinhole.fx * u.x + pinhole.cx);
      map_y.at<float>(y, x) = static_cast<float>(pinhole.fy * u.y + pinhole.cy);
    }
  }
  // An oversampled pinhole image is read bicubically (sharper than bilinear
  // between its samples; its undershoot below zero at silhouettes clipped),
  // a camera-resolution one bilinearly (no ringing at a pixel's scale).
  cv::Mat out;
  if (oversampling > 1) {
    cv::remap(undistorted, out, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_CONSTANT, cv::Scalar::all(0));
    out = cv::max(out, 0.0);
  } else {
    cv::remap(undistorted, out, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  }
  return out;
}

namespace {

template <typename T>
cv::Mat Encode(const cv::Mat& linear_rgb, const EncodeOptions& options, std::mt19937& rng) {
  CV_Assert(linear_rgb.type() == CV_32FC3);
  constexpr float kTop = static_cast<float>(std::numeric_limits<T>::max());
  cv::Mat out(linear_rgb.rows, linear_rgb.cols, CV_MAKETYPE(cv::DataType<T>::depth, 3));
  std::normal_distribution<float> noise(0.0f, static_cast<float>(options.noise_sigma) * kTop / 255.0f);
  const bool noisy = options.noise_sigma > 0.0;
  const float gain = static_cast<float>(options.exposure);
  for (int y = 0; y < linear_rgb.rows; ++y) {
    const cv::Vec3f* in = linear_rgb.ptr<cv::Vec3f>(y);
    cv::Vec<T, 3>* o = out.ptr<cv::Vec<T, 3>>(y);
    for (int x = 0; x < linear_rgb.cols; ++x) {
      for (int c = 0; c < 3; ++c) {
        const float lin = std::clamp(in[x][c] * gain, 0.0f, 1.0f);
        float code = kTop * scene::LinearToSrgb(lin);
        if (noisy) code += noise(rng);
        // RGB in, BGR out.
        o[x][2 - c] = static_cast<T>(std::clamp(std::lround(code), 0L, static_cast<long>(kTop)));
      }
    }
  }
  return out;
}

}  // namespace

cv::Mat EncodeSrgb8(const cv::Mat& linear_rgb, const EncodeOptions& options, std::mt19937& rng) {
  return Encode<uint8_t>(linear_rgb, options, rng);
}

cv::Mat EncodeSrgb(const cv::Mat& linear_rgb, const EncodeOptions& options, int bits, std::mt19937& rng) {
  return bits == 16 ? Encode<uint16_t>(linear_rgb, options, rng) : Encode<uint8_t>(linear_rgb, options, rng);
}

}  // namespace mvbrdf::synth
