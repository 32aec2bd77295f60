// Turns a rendered linear radiance image into what a camera would store:
// lens distortion, exposure, clipping, sRGB encoding, sensor noise and 8-bit
// quantisation.
#ifndef MVBRDF_CORE_SYNTH_FRAME_ENCODER_H_
#define MVBRDF_CORE_SYNTH_FRAME_ENCODER_H_

#include <cstdint>
#include <random>

#include <opencv2/core.hpp>

#include "core/scene/camera_model.h"

namespace mvbrdf::synth {

// Warps an undistorted pinhole image (same intrinsics) into the camera's
// distorted image: each output pixel samples the pinhole image at its
// undistorted position (bilinear). Returns the input when there is no
// distortion. `image` may have any float type.
cv::Mat ApplyDistortion(const cv::Mat& undistorted, const scene::CameraModel& camera);

struct EncodeOptions {
  double exposure = 1.0;     // gain before clipping to [0, 1]
  double noise_sigma = 0.0;  // Gaussian, in 8-bit code values, after encoding
};

// CV_32FC3 linear RGB -> CV_8UC3 sRGB in OpenCV's BGR order, ready for
// cv::VideoWriter / cv::imwrite.
cv::Mat EncodeSrgb8(const cv::Mat& linear_rgb, const EncodeOptions& options, std::mt19937& rng);
// The same with `bits` 8 or 16 per channel (CV_8UC3 or CV_16UC3); the noise
// is the same in light (noise_sigma 8-bit code values are 257 16-bit ones).
cv::Mat EncodeSrgb(const cv::Mat& linear_rgb, const EncodeOptions& options, int bits, std::mt19937& rng);

}  // namespace mvbrdf::synth

#endif  // MVBRDF_CORE_SYNTH_FRAME_ENCODER_H_
