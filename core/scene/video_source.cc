#include "core/scene/video_source.h"

#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"

namespace mvbrdf::scene {

float SrgbToLinear(float encoded) {
  // IEC 61966-2-1, the exact piecewise curve (not a 2.2 gamma).
  if (encoded <= 0.04045f) return encoded / 12.92f;
  return static_cast<float>(std::pow((static_cast<double>(encoded) + 0.055) / 1.055, 2.4));
}

float LinearToSrgb(float linear) {
  if (linear <= 0.0031308f) return linear * 12.92f;
  return static_cast<float>(1.055 * std::pow(static_cast<double>(linear), 1.0 / 2.4) - 0.055);
}

namespace {

// Per-code-value lookup table: code / max_code, then the transfer curve.
// 256 or 65536 entries, built once per source.
std::vector<float> MakeDecodeTable(int bit_depth, bool srgb) {
  const int max_code = bit_depth == 16 ? 65535 : 255;
  std::vector<float> table(static_cast<size_t>(max_code) + 1);
  for (int i = 0; i <= max_code; ++i) {
    const float v = static_cast<float>(static_cast<double>(i) / max_code);
    table[static_cast<size_t>(i)] = srgb ? SrgbToLinear(v) : v;
  }
  return table;
}

// Which pixels of a frame may become Samples (video.h kMaskedPixel,
// kSaturatedPixel): a stored code value at or above `saturation_code` in any
// colour channel (alpha is not one) is saturated; `mask` (CV_8UC1 of the
// frame's size, 0 = not usable) or empty.
struct PixelValidity {
  uint32_t saturation_code = UINT32_MAX;  // never
  cv::Mat mask;
};

// Stored frame (8/16-bit, 1/3/4 channels in OpenCV's BGR order) -> CV_32FC3
// linear RGB.
template <typename T>
cv::Mat DecodeTyped(const cv::Mat& stored, const std::vector<float>& table, const PixelValidity& validity) {
  cv::Mat out(stored.rows, stored.cols, CV_32FC3);
  const int channels = stored.channels();
  const int colours = channels == 1 ? 1 : 3;
  const uint32_t level = validity.saturation_code;
  for (int y = 0; y < stored.rows; ++y) {
    const T* in = stored.ptr<T>(y);
    cv::Vec3f* o = out.ptr<cv::Vec3f>(y);
    const uint8_t* usable = validity.mask.empty() ? nullptr : validity.mask.ptr<uint8_t>(y);
    for (int x = 0; x < stored.cols; ++x) {
      const T* px = in + static_cast<ptrdiff_t>(x) * channels;
      if (usable != nullptr && usable[x] == 0) {
        o[x] = cv::Vec3f::all(kMaskedPixel);
        continue;
      }
      bool saturated = false;
      for (int c = 0; c < colours; ++c) saturated = saturated || px[c] >= level;
      if (saturated) {
        o[x] = cv::Vec3f::all(kSaturatedPixel);
      } else if (channels == 1) {
        const float g = table[px[0]];
        o[x] = cv::Vec3f(g, g, g);
      } else {
        o[x] = cv::Vec3f(table[px[2]], table[px[1]], table[px[0]]);  // BGR(A) -> RGB
      }
    }
  }
  return out;
}

absl::StatusOr<cv::Mat> Decode(const cv::Mat& stored, int bit_depth, const std::vector<float>& table,
                               const std::string& what, const PixelValidity& validity = {}) {
  const int channels = stored.channels();
  if (channels != 1 && channels != 3 && channels != 4) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": has ", channels, " channels, expected 1, 3 or 4"));
  }
  const int depth = stored.depth();
  if (depth == CV_8U && bit_depth == 8) return DecodeTyped<uint8_t>(stored, table, validity);
  if (depth == CV_16U && bit_depth == 16) return DecodeTyped<uint16_t>(stored, table, validity);
  const char* stored_bits = depth == CV_8U ? "8-bit" : depth == CV_16U ? "16-bit" : "neither 8- nor 16-bit";
  return absl::InvalidArgumentError(
      absl::StrCat(what, ": is ", stored_bits, ", expected ", bit_depth, "-bit (video.bit_depth)"));
}

absl::Status CheckSize(const cv::Mat& frame, int width, int height, const std::string& what) {
  if (frame.cols == width && frame.rows == height) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(what, ": is ", frame.cols, "x", frame.rows, ", expected ", width, "x", height));
}

// The camera's mask (video.mask_path): one image, or one per absolute frame
// index; non-zero in any channel = usable. Read as CV_8UC1 0 / 255.
class MaskReader {
 public:
  MaskReader(std::filesystem::path dir, std::string pattern, int width, int height, std::string field)
      : dir_(std::move(dir)), pattern_(std::move(pattern)), width_(width), height_(height), field_(std::move(field)) {}

  // The mask of absolute frame `index`; empty when the camera has none.
  absl::StatusOr<cv::Mat> MaskOf(int index) {
    if (pattern_.empty()) return cv::Mat();
    const bool per_frame = IsFramePattern(pattern_);
    if (!per_frame && !cached_.empty()) return cached_;
    const std::string shown = per_frame ? FormatFramePattern(pattern_, index) : pattern_;
    const std::string path = ResolvePath(dir_, shown).string();
    const std::string what =
        absl::StrCat(field_, ".video.mask_path", per_frame ? absl::StrCat(" (frame ", index, ")") : "", ": ",
                     ElideForMessage(shown, kMaxShownPathChars));
    if (const std::string why = WhyNotRegularFile(path); !why.empty()) {
      return NotRegularFileError(why, absl::StrCat(what, ": mask image ", why));
    }
    const cv::Mat stored = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (stored.empty()) return absl::InvalidArgumentError(absl::StrCat(what, ": cannot decode image"));
    if (stored.cols != width_ || stored.rows != height_) {
      return absl::InvalidArgumentError(absl::StrCat(what, ": is ", stored.cols, "x", stored.rows, ", expected ",
                                                     width_, "x", height_, " (camera width x height)"));
    }
    std::vector<cv::Mat> planes;
    cv::split(stored, planes);
    cv::Mat usable = cv::Mat::zeros(stored.rows, stored.cols, CV_8UC1);
    for (const cv::Mat& plane : planes) usable.setTo(255, plane != 0);
    if (!per_frame) cached_ = usable;
    return usable;
  }

 private:
  std::filesystem::path dir_;
  std::string pattern_;
  int width_, height_;
  std::string field_;
  cv::Mat cached_;
};

// "cam0/%04d.png" numbered by absolute frame index.
class ImageSequenceSource : public VideoSource {
 public:
  ImageSequenceSource(std::filesystem::path dir, std::string pattern, FrameSelection selection, int num_frames,
                      int width, int height, int bit_depth, bool srgb, PixelValidity validity, MaskReader mask,
                      std::string field)
      : dir_(std::move(dir)),
        pattern_(std::move(pattern)),
        selection_(std::move(selection)),
        num_frames_(num_frames),
        width_(width),
        height_(height),
        bit_depth_(bit_depth),
        table_(MakeDecodeTable(bit_depth, srgb)),
        validity_(std::move(validity)),
        mask_(std::move(mask)),
        field_(std::move(field)) {}

  // Frame `index` (absolute). The pattern is expanded before it is joined to
  // the directory, so a '%' in the directory is not taken for a conversion.
  std::string PathOf(int index) const { return ResolvePath(dir_, FormatFramePattern(pattern_, index)).string(); }
  // Frame `index` as errors name it: relative to the scene's directory, as
  // the scene names it (not the directory's private location on a worker).
  std::string ShownPathOf(int index) const { return FormatFramePattern(pattern_, index); }

  absl::StatusOr<VideoProbe> Probe() override {
    const int first_frame = selection_.Absolute(0);
    const std::string first = PathOf(first_frame);
    const cv::Mat image = cv::imread(first, cv::IMREAD_UNCHANGED);
    if (image.empty()) {
      return absl::InvalidArgumentError(absl::StrCat(field_, ".video: cannot decode image ", ShownPathOf(first_frame)));
    }
    const int stored_bits = image.depth() == CV_8U ? 8 : image.depth() == CV_16U ? 16 : 0;
    if (stored_bits != bit_depth_) {
      return absl::InvalidArgumentError(
          absl::StrCat(field_, ".video: frame 0 (", ShownPathOf(first_frame), ") is ",
                       stored_bits == 0 ? "neither 8- nor 16-bit" : absl::StrCat(stored_bits, "-bit"), ", expected ",
                       bit_depth_, "-bit (video.bit_depth)"));
    }
    VideoProbe probe;
    probe.width = image.cols;
    probe.height = image.rows;
    std::error_code ec;
    // Unbounded (num_frames < 0): every consecutive file from the first.
    while ((num_frames_ < 0 || probe.frame_count < num_frames_) &&
           (selection_.indices.empty() || probe.frame_count < static_cast<int>(selection_.indices.size())) &&
           std::filesystem::is_regular_file(PathOf(selection_.Absolute(probe.frame_count)), ec)) {
      ++probe.frame_count;
    }
    return probe;
  }

  absl::StatusOr<cv::Mat> ReadFrame(int t) override {
    if (t < 0) return absl::OutOfRangeError(absl::StrCat(field_, ".video: frame ", t, " is negative"));
    if (!selection_.indices.empty() && t >= static_cast<int>(selection_.indices.size())) {
      return absl::OutOfRangeError(absl::StrCat(field_, ".video: frame ", t, " is past the selected frames"));
    }
    const int index = selection_.Absolute(t);
    const std::string path = PathOf(index);
    const std::string what = absl::StrCat(field_, ".video: frame ", t, " (", ShownPathOf(index), ")");
    if (const std::string why = WhyNotRegularFile(path); !why.empty()) {
      return NotRegularFileError(why, absl::StrCat(what, ": ", why));
    }
    const cv::Mat stored = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (stored.empty()) return absl::InvalidArgumentError(absl::StrCat(what, ": cannot decode image"));
    const absl::Status size = CheckSize(stored, width_, height_, what);
    if (!size.ok()) return size;
    PixelValidity validity = validity_;
    MVBRDF_ASSIGN_OR_RETURN(validity.mask, mask_.MaskOf(index));
    return Decode(stored, bit_depth_, table_, what, validity);
  }

 private:
  std::filesystem::path dir_;
  std::string pattern_;
  FrameSelection selection_;
  int num_frames_;  // < 0: unbounded
  int width_, height_;
  int bit_depth_;
  std::vector<float> table_;
  PixelValidity validity_;
  MaskReader mask_;
  std::string field_;
};

// A video file decoded by OpenCV's FFmpeg backend (8-bit BGR frames).
class VideoFileSource : public VideoSource {
 public:
  // `path` is opened; `shown` names it in errors (the scene's relative path).
  VideoFileSource(std::string path, std::string shown, FrameSelection selection, int num_frames, int width, int height,
                  bool srgb, PixelValidity validity, MaskReader mask, std::string field)
      : path_(std::move(path)),
        shown_(std::move(shown)),
        selection_(std::move(selection)),
        num_frames_(num_frames),
        width_(width),
        height_(height),
        table_(MakeDecodeTable(8, srgb)),
        validity_(std::move(validity)),
        mask_(std::move(mask)),
        field_(std::move(field)) {}

  absl::Status Reopen() {
    capture_.release();
    if (!capture_.open(path_, cv::CAP_FFMPEG)) {
      return absl::InvalidArgumentError(
          absl::StrCat(field_, ".video.path: cannot open video ", shown_, " (not a video FFmpeg can decode?)"));
    }
    next_ = 0;
    return absl::OkStatus();
  }

  absl::StatusOr<VideoProbe> Probe() override {
    cv::VideoCapture capture;
    if (!capture.open(path_, cv::CAP_FFMPEG)) {
      return absl::InvalidArgumentError(absl::StrCat(field_, ".video.path: cannot open video ", shown_));
    }
    VideoProbe probe;
    probe.width = static_cast<int>(capture.get(cv::CAP_PROP_FRAME_WIDTH));
    probe.height = static_cast<int>(capture.get(cv::CAP_PROP_FRAME_HEIGHT));
    const double stated = capture.get(cv::CAP_PROP_FRAME_COUNT);
    int total = 0;
    if (stated > 0) {
      total = static_cast<int>(std::lround(stated));
    } else {
      // The container does not say: count by demuxing (grab does not decode
      // into a Mat, so this is cheap next to reading).
      while (capture.grab()) ++total;
    }
    // Selected frames whose file frame lies before the end.
    if (!selection_.indices.empty()) {
      while (probe.frame_count < static_cast<int>(selection_.indices.size()) &&
             selection_.indices[static_cast<size_t>(probe.frame_count)] < total) {
        ++probe.frame_count;
      }
    } else {
      const int after_first = total - selection_.first;
      probe.frame_count = after_first <= 0 ? 0 : (after_first + selection_.step - 1) / selection_.step;
      if (num_frames_ >= 0) probe.frame_count = std::min(probe.frame_count, num_frames_);
    }
    return probe;
  }

  absl::StatusOr<cv::Mat> ReadFrame(int t) override {
    if (t < 0) return absl::OutOfRangeError(absl::StrCat(field_, ".video: frame ", t, " is negative"));
    if (!selection_.indices.empty() && t >= static_cast<int>(selection_.indices.size())) {
      return absl::OutOfRangeError(absl::StrCat(field_, ".video: frame ", t, " is past the selected frames"));
    }
    const int index = selection_.Absolute(t);  // absolute index in the file
    if (!capture_.isOpened() || index < next_) {
      const absl::Status status = Reopen();
      if (!status.ok()) return status;
    }
    // Skip forward frame by frame: seeking by timestamp is not frame-exact in
    // every container.
    while (next_ < index) {
      if (!capture_.grab()) return EndOfVideo(t);
      ++next_;
    }
    cv::Mat stored;
    if (!capture_.read(stored) || stored.empty()) return EndOfVideo(t);
    ++next_;
    const std::string what = absl::StrCat(field_, ".video: frame ", t, " of ", shown_);
    const absl::Status size = CheckSize(stored, width_, height_, what);
    if (!size.ok()) return size;
    PixelValidity validity = validity_;
    MVBRDF_ASSIGN_OR_RETURN(validity.mask, mask_.MaskOf(index));
    return Decode(stored, 8, table_, what, validity);
  }

 private:
  absl::Status EndOfVideo(int t) {
    capture_.release();
    return absl::OutOfRangeError(absl::StrCat(field_, ".video: frame ", t, " (file frame ", selection_.Absolute(t),
                                              ") is past the end of ", shown_));
  }

  std::string path_;
  std::string shown_;
  FrameSelection selection_;
  int num_frames_;  // < 0: unbounded
  int width_, height_;
  std::vector<float> table_;
  PixelValidity validity_;
  MaskReader mask_;
  std::string field_;
  cv::VideoCapture capture_;
  int next_ = 0;  // absolute index of the frame the next read() returns
};

}  // namespace

FrameSelection CameraFrames(const FrameSelection& selection, const v1::Video& video) {
  FrameSelection shifted = selection;
  shifted.first += video.frame_offset();
  for (int& index : shifted.indices) index += video.frame_offset();
  return shifted;
}

absl::StatusOr<cv::Mat> ReadLinearRgbImage(const std::filesystem::path& file, bool srgb) {
  const cv::Mat stored = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
  if (stored.empty()) return absl::NotFoundError(absl::StrCat(file.string(), ": cannot read image"));
  const int bit_depth = stored.depth() == CV_16U ? 16 : 8;
  return Decode(stored, bit_depth, MakeDecodeTable(bit_depth, srgb), file.string());
}

absl::StatusOr<std::unique_ptr<VideoSource>> VideoSource::Open(const v1::Camera& camera,
                                                               const std::filesystem::path& scene_dir, int first_frame,
                                                               absl::string_view field) {
  FrameSelection selection;
  selection.first = first_frame;
  return Open(camera, scene_dir, selection, -1, field);
}

absl::StatusOr<std::unique_ptr<VideoSource>> VideoSource::Open(const v1::Camera& camera,
                                                               const std::filesystem::path& scene_dir,
                                                               const FrameSelection& sequence_frames, int num_frames,
                                                               absl::string_view field) {
  const v1::Video& video = camera.video();
  const FrameSelection selection = CameraFrames(sequence_frames, video);
  const int first_frame = selection.Absolute(0);
  const std::string path_field = absl::StrCat(field, ".video.path");
  if (video.path().empty()) return absl::InvalidArgumentError(absl::StrCat(path_field, ": required"));
  const absl::Status pattern_ok = ValidateFramePattern(video.path(), path_field);
  if (!pattern_ok.ok()) return pattern_ok;
  const int bit_depth = video.bit_depth() == 0 ? 8 : static_cast<int>(video.bit_depth());
  if (bit_depth != 8 && bit_depth != 16) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".video.bit_depth: must be 0, 8 or 16, got ", video.bit_depth()));
  }
  if (first_frame < 0) {
    if (video.frame_offset() != 0) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ".video.frame_offset: frame ", sequence_frames.Absolute(0), " of the sequence is frame ",
                       first_frame, " of the video, before its start (frame_offset ", video.frame_offset(), ")"));
    }
    return absl::InvalidArgumentError(absl::StrCat(field, ": first frame must be >= 0, got ", first_frame));
  }
  const bool srgb = video.encoding() != v1::LINEAR;
  PixelValidity validity;
  const uint32_t top_code = bit_depth == 16 ? 65535u : 255u;
  validity.saturation_code = video.has_saturation_level() ? video.saturation_level() : top_code;
  if (validity.saturation_code == 0 || validity.saturation_code > top_code + 1) {
    return absl::InvalidArgumentError(absl::StrCat(field, ".video.saturation_level: must be in [1, ", top_code + 1,
                                                   "] (stored code values of ", bit_depth, "-bit frames), got ",
                                                   validity.saturation_code));
  }
  MaskReader mask(scene_dir, video.mask_path(), static_cast<int>(camera.width()), static_cast<int>(camera.height()),
                  std::string(field));
  if (IsFramePattern(video.path())) {
    const std::string shown = FormatFramePattern(video.path(), first_frame);
    const std::string first = ResolvePath(scene_dir, shown).string();
    if (const std::string why = WhyNotRegularFile(first); !why.empty()) {
      return NotRegularFileError(
          why, absl::StrCat(path_field, ": first frame ", why, ": ", ElideForMessage(shown, kMaxShownPathChars)));
    }
    return std::unique_ptr<VideoSource>(new ImageSequenceSource(
        scene_dir, video.path(), selection, num_frames, static_cast<int>(camera.width()),
        static_cast<int>(camera.height()), bit_depth, srgb, std::move(validity), std::move(mask), std::string(field)));
  }
  const std::string path = ResolvePath(scene_dir, video.path()).string();
  if (const std::string why = WhyNotRegularFile(path); !why.empty()) {
    return NotRegularFileError(
        why, absl::StrCat(path_field, ": video file ", why, ": ", ElideForMessage(video.path(), kMaxShownPathChars)));
  }
  if (bit_depth != 8) {
    return absl::InvalidArgumentError(
        absl::StrCat(field,
                     ".video.bit_depth: video files are decoded as 8-bit; store 16-bit frames as an image sequence "
                     "(e.g. \"cam0/%04d.png\")"));
  }
  auto source = std::make_unique<VideoFileSource>(path, video.path(), selection, num_frames,
                                                  static_cast<int>(camera.width()), static_cast<int>(camera.height()),
                                                  srgb, std::move(validity), std::move(mask), std::string(field));
  const absl::Status opened = source->Reopen();
  if (!opened.ok()) return opened;
  return std::unique_ptr<VideoSource>(std::move(source));
}

}  // namespace mvbrdf::scene
