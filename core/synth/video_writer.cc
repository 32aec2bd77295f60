#include "core/synth/video_writer.h"

#include <opencv2/imgcodecs.hpp>

#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"

namespace mvbrdf::synth {

absl::StatusOr<std::unique_ptr<FrameSink>> FrameSink::Open(const std::filesystem::path& stem,
                                                           const std::filesystem::path& scene_dir, VideoCodec codec,
                                                           int width, int height, double fps, int first_frame) {
  auto sink = std::make_unique<FrameSink>();
  sink->codec_ = codec;
  sink->width_ = width;
  sink->height_ = height;
  sink->next_frame_ = first_frame;
  std::error_code ec;
  std::filesystem::create_directories(stem.parent_path(), ec);
  const auto relative = [&](const std::filesystem::path& p) { return p.lexically_relative(scene_dir).generic_string(); };
  switch (codec) {
    case VideoCodec::kPngSequence: {
      std::filesystem::create_directories(stem, ec);
      if (ec) return ErrnoStatus(ec.value(), "cannot create directory", stem.string());
      sink->file_ = stem / "%04d.png";
      sink->scene_path_ = relative(sink->file_);
      return sink;
    }
    case VideoCodec::kFfv1:
    case VideoCodec::kMpeg4Lossy: {
      const bool lossless = codec == VideoCodec::kFfv1;
      sink->file_ = stem.string() + (lossless ? ".mkv" : ".mp4");
      const int fourcc = lossless ? cv::VideoWriter::fourcc('F', 'F', 'V', '1') : cv::VideoWriter::fourcc('m', 'p', '4', 'v');
      if (!sink->writer_.open(sink->file_.string(), cv::CAP_FFMPEG, fourcc, fps, cv::Size(width, height), true)) {
        return absl::UnavailableError(absl::StrCat(sink->file_.string(),
                                                   ": OpenCV's FFmpeg backend cannot write this codec"));
      }
      sink->scene_path_ = relative(sink->file_);
      return sink;
    }
  }
  return absl::InvalidArgumentError("unknown codec");
}

absl::Status FrameSink::Write(const cv::Mat& bgr8) {
  // 16-bit frames only as PNG images (video codecs here are 8-bit).
  const bool ok_type = bgr8.type() == CV_8UC3 || (bgr8.type() == CV_16UC3 && codec_ == VideoCodec::kPngSequence);
  if (!ok_type || bgr8.cols != width_ || bgr8.rows != height_) {
    return absl::InvalidArgumentError(absl::StrCat(file_.string(), ": frame must be ", width_, "x", height_,
                                                   " CV_8UC3 (CV_16UC3 for a PNG sequence)"));
  }
  if (codec_ == VideoCodec::kPngSequence) {
    const std::string path = FormatFramePattern(file_.string(), next_frame_);
    // Encoded in memory and written checked, to a temporary renamed into place.
    std::vector<uchar> png;
    if (!cv::imencode(".png", bgr8, png)) return absl::InternalError(absl::StrCat(path, ": cannot encode PNG"));
    MVBRDF_RETURN_IF_ERROR(
        WriteStringToFile(path, absl::string_view(reinterpret_cast<const char*>(png.data()), png.size())));
  } else {
    writer_.write(bgr8);
  }
  ++next_frame_;
  return absl::OkStatus();
}

absl::Status FrameSink::Close() {
  if (writer_.isOpened()) writer_.release();
  return absl::OkStatus();
}

}  // namespace mvbrdf::synth
