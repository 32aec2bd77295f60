// Float images on disk: OpenEXR for data (lossless, linear), PNG previews for
// people. Images in memory are OpenCV matrices with channels in R, G, B(, A)
// order (docs/architecture.md), row 0 at the top.
#ifndef MVBRDF_CORE_IMAGE_EXR_H_
#define MVBRDF_CORE_IMAGE_EXR_H_

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"

namespace mvbrdf::image {

struct ExrOptions {
  // Store 16-bit half floats (half the size; ~3 significant digits, plenty for
  // radiance previews) instead of 32-bit floats.
  bool half = false;
  // Channel names, one per image channel; empty: "Y" for one channel, R,G,B
  // for three, R,G,B,A for four.
  std::vector<std::string> channel_names;
};

// Writes CV_32F (1-4 channels) as float/half channels, or CV_16U / CV_32S
// images as UINT channels (masks, triangle ids; -1 becomes 0xffffffff): one
// channel, or any number with options.channel_names. ZIP compression. Written to a temporary file and renamed,
// every write checked (a full disk is RESOURCE_EXHAUSTED, nothing left behind).
absl::Status WriteExr(const std::filesystem::path& file, const cv::Mat& image, const ExrOptions& options = {});

struct ExrImage {
  cv::Mat image;                           // CV_32FC(n) for float/half files, CV_32SC(n) for UINT channels
  std::vector<std::string> channel_names;  // in the order of image's channels
};

// Reads an EXR written by WriteExr (or any scanline EXR with up to 4 float
// or half channels, or only uint channels): channels come back in the order R, G, B, A, Y, then
// any others by name.
absl::StatusOr<ExrImage> ReadExr(const std::filesystem::path& file);

// An 8-bit sRGB PNG of a linear RGB(A) CV_32FC3/CV_32FC4 image for people:
// values times `gain`, clipped, sRGB-encoded; alpha (when present) becomes the
// PNG's alpha, so invalid texels show as transparent. CV_32FC1 gives grey.
// Written to a temporary file and renamed, every write checked (a full disk is
// RESOURCE_EXHAUSTED, nothing left behind).
absl::Status WritePngPreview(const std::filesystem::path& file, const cv::Mat& linear, float gain = 1.0f);
// The same preview as PNG bytes, in memory.
absl::StatusOr<std::string> EncodePngPreview(const cv::Mat& linear, float gain = 1.0f);
// Any 8- or 16-bit image OpenCV can store as PNG (BGR channel order) as PNG bytes.
absl::StatusOr<std::string> EncodePng(const cv::Mat& image);

}  // namespace mvbrdf::image

#endif  // MVBRDF_CORE_IMAGE_EXR_H_
