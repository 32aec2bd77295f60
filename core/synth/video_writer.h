// Writes one camera's 8-bit frames: FFV1 lossless video (.mkv), MPEG-4 lossy
// video (.mp4), or a PNG sequence, through OpenCV.
#ifndef MVBRDF_CORE_SYNTH_VIDEO_WRITER_H_
#define MVBRDF_CORE_SYNTH_VIDEO_WRITER_H_

#include <filesystem>
#include <memory>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "absl/status/statusor.h"

namespace mvbrdf::synth {

enum class VideoCodec { kFfv1, kMpeg4Lossy, kPngSequence };

class FrameSink {
 public:
  // `stem` is the path without extension, e.g. out/videos/cam0. The path the
  // scene should reference (relative to `scene_dir`) is scene_path().
  static absl::StatusOr<std::unique_ptr<FrameSink>> Open(const std::filesystem::path& stem,
                                                         const std::filesystem::path& scene_dir, VideoCodec codec,
                                                         int width, int height, double fps, int first_frame);
  // Appends a CV_8UC3 BGR frame (or CV_16UC3 to a PNG sequence).
  absl::Status Write(const cv::Mat& bgr8);
  absl::Status Close();
  const std::string& scene_path() const { return scene_path_; }

 private:
  VideoCodec codec_ = VideoCodec::kFfv1;
  std::filesystem::path file_;
  std::string scene_path_;
  cv::VideoWriter writer_;
  int next_frame_ = 0;
  int width_ = 0, height_ = 0;
};

}  // namespace mvbrdf::synth

#endif  // MVBRDF_CORE_SYNTH_VIDEO_WRITER_H_
