// Reads one camera's frames: a video file (OpenCV's FFmpeg backend) or an
// image-sequence pattern, returned as linear RGB float images.
#ifndef MVBRDF_CORE_SCENE_VIDEO_SOURCE_H_
#define MVBRDF_CORE_SCENE_VIDEO_SOURCE_H_

#include <filesystem>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "mvbrdf/v1/scene.pb.h"

namespace mvbrdf::scene {

struct VideoProbe {
  int width = 0;
  int height = 0;
  int frame_count = 0;  // frames available from the first used frame on (of the selection)
};

// Which file or video frames are the sequence's frames t = 0, 1, ...
// (scene.frames): first + t * step, or indices[t] when indices are given.
struct FrameSelection {
  int first = 0;
  int step = 1;
  std::vector<int> indices;  // absolute, strictly increasing; empty: first + t * step
  int Absolute(int t) const {
    return indices.empty() ? first + t * step : indices[static_cast<size_t>(t)];
  }
};

// The file frames of one camera (Video.frame_offset, issue #20): the
// sequence's `selection` shifted by `video.frame_offset`, so that absolute
// frame f of the sequence is frame f + frame_offset of the camera's video,
// image sequence and mask pattern. Validated scenes keep every shifted frame
// in [0, 2^31 - 1).
FrameSelection CameraFrames(const FrameSelection& selection, const v1::Video& video);

// Mask and saturation (Video.mask_path, saturation_level): a decoded frame
// holds a negative value in every channel of a pixel that must never become
// a Sample: kMaskedPixel outside the mask, kSaturatedPixel where a stored
// channel is at or above the saturation level. Consumers (the resampler, the
// per-pixel Samples) refuse such pixels.
inline constexpr float kMaskedPixel = -1.0f;
inline constexpr float kSaturatedPixel = -2.0f;

class VideoSource {
 public:
  // `scene_dir` resolves the relative path; `first_frame` is the scene's
  // frames.first; `field` names the camera in errors ("scene.cameras[2]").
  static absl::StatusOr<std::unique_ptr<VideoSource>> Open(const v1::Camera& camera,
                                                           const std::filesystem::path& scene_dir,
                                                           int first_frame, absl::string_view field);
  // The frames of `selection` (the sequence's); frame t of ReadFrame is file
  // frame CameraFrames(selection, camera.video()).Absolute(t).
  static absl::StatusOr<std::unique_ptr<VideoSource>> Open(const v1::Camera& camera,
                                                           const std::filesystem::path& scene_dir,
                                                           const FrameSelection& selection, int num_frames,
                                                           absl::string_view field);
  virtual ~VideoSource() = default;

  // Width, height and number of readable frames (a video whose container does
  // not state its frame count is counted by decoding).
  virtual absl::StatusOr<VideoProbe> Probe() = 0;
  // Frame t (0-based, of the selection) as CV_32FC3 linear RGB in [0,1],
  // row 0 = top, with masked and saturated pixels marked (kMaskedPixel,
  // kSaturatedPixel). Sequential reads are fast; seeking backwards reopens.
  virtual absl::StatusOr<cv::Mat> ReadFrame(int t) = 0;
};

// Reads one 8- or 16-bit image file (any format cv::imread knows) as CV_32FC3
// linear RGB in [0,1], row 0 = top; sRGB-decoded when `srgb`.
absl::StatusOr<cv::Mat> ReadLinearRgbImage(const std::filesystem::path& file, bool srgb);

// sRGB transfer: code value in [0,1] <-> linear in [0,1].
float SrgbToLinear(float encoded);
float LinearToSrgb(float linear);

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_VIDEO_SOURCE_H_
