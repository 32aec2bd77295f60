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

// Warps an undistorted pinhole image into the camera's distorted image: each
// output pixel samples the pinhole image at its undistorted position
// (bilinear at oversampling 1, bicubic above, negative values clipped). The
// pinhole image is that of scene::Supersampled(camera, oversampling) (same
// focal lengths and principal point at `oversampling` times the resolution);
// the result has the camera's size. A lookup blurs by up to one pinhole
// pixel, so a pinhole image at 4x the resolution, read bicubically, gives the
// distorted image nearly as if each pixel were point-sampled at its own ray
// (kDistortionOversampling). Returns the input when there is no distortion
// and oversampling is 1. `image` may have any float type.
cv::Mat ApplyDistortion(const cv::Mat& undistorted, const scene::CameraModel& camera, int oversampling = 1);

// The pinhole resolution factor the generator renders a distorted camera's
// images at (synthesizer.cc RenderPixelAreas) when each pixel is one sample:
// at 1 the bilinear warp blurs a sharp highlight and the silhouette by a
// pixel (hair's ks / ke 0.21 / 0.12 off on the studio actor with k1 -0.05 and
// exact cameras, against 0.01 / 0.004 without distortion). Hair's highlight
// there is under a pixel wide, so even a quarter pixel's blur shows: at 4x
// bilinear 0.095 / 0.115, at 4x bicubic 0.024 / 0.058 (7x bilinear 0.052 /
// 0.077; seed 3, `synth --distortion -0.05`, `run --no-powell`, the run
// still interpolating a distorted pixel's surface; reading it off the ray's
// own triangle, samples::assemble_internal::SurfaceOnRay: 0.011 / 0.009).
inline constexpr int kDistortionOversampling = 4;

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
