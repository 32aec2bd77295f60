#include "core/scene/video_source.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "core/scene/scene_test_util.h"

namespace mvbrdf::scene {
namespace {

using testing::TempDir;

constexpr float kCurveTolerance = 1e-6f;

v1::Camera MakeCamera(const std::string& path, int width, int height, v1::ColorEncoding encoding, int bit_depth) {
  v1::Camera camera;
  camera.set_name("cam");
  camera.set_width(width);
  camera.set_height(height);
  camera.mutable_video()->set_path(path);
  camera.mutable_video()->set_encoding(encoding);
  camera.mutable_video()->set_bit_depth(bit_depth);
  // The decoding tests use every code value: none is taken as saturated here
  // (SaturationAndMask tests the default).
  camera.mutable_video()->set_saturation_level(bit_depth == 16 ? 65536 : 256);
  return camera;
}

// Deterministic BGR test pattern for frame t: every pixel different.
cv::Mat Pattern(int t, int width, int height) {
  cv::Mat image(height, width, CV_8UC3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      image.at<cv::Vec3b>(y, x) =
          cv::Vec3b(static_cast<uchar>((x * 7 + t * 31) & 255), static_cast<uchar>((y * 11 + t * 5) & 255),
                    static_cast<uchar>((x * y + t * 17) & 255));
    }
  }
  return image;
}

// frame: CV_32FC3 RGB in [0,1], linear encoding; expected: BGR 8-bit.
void ExpectEqualsBgr8(const cv::Mat& frame, const cv::Mat& expected) {
  ASSERT_EQ(frame.type(), CV_32FC3);
  ASSERT_EQ(frame.size(), expected.size());
  int mismatches = 0;
  for (int y = 0; y < frame.rows; ++y) {
    for (int x = 0; x < frame.cols; ++x) {
      const cv::Vec3f rgb = frame.at<cv::Vec3f>(y, x);
      const cv::Vec3b bgr = expected.at<cv::Vec3b>(y, x);
      for (int c = 0; c < 3; ++c) mismatches += std::lround(rgb[c] * 255.0f) != bgr[2 - c];
    }
  }
  EXPECT_EQ(mismatches, 0);
}

TEST(SrgbTest, ExactPiecewiseCurve) {
  EXPECT_EQ(SrgbToLinear(0.0f), 0.0f);
  EXPECT_NEAR(SrgbToLinear(1.0f), 1.0f, kCurveTolerance);
  EXPECT_NEAR(SrgbToLinear(0.04045f), 0.04045f / 12.92f, kCurveTolerance);
  EXPECT_NEAR(SrgbToLinear(0.5f), 0.2140411f, kCurveTolerance);  // not 0.5^2.2 = 0.2176
  EXPECT_NEAR(LinearToSrgb(0.0031308f), 0.04045f, 1e-5f);
  EXPECT_NEAR(LinearToSrgb(0.2140411f), 0.5f, kCurveTolerance);
  for (int i = 0; i <= 1000; ++i) {
    const float x = i / 1000.0f;
    EXPECT_NEAR(LinearToSrgb(SrgbToLinear(x)), x, 2e-6f) << x;
  }
}

TEST(VideoSourceTest, Ffv1RoundTripIsBitExact) {
  TempDir dir;
  constexpr int kWidth = 40, kHeight = 30, kFrames = 6;
  const std::string file = (dir / "cam0.mkv").string();
  {
    cv::VideoWriter writer(file, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 25.0,
                           cv::Size(kWidth, kHeight));
    ASSERT_TRUE(writer.isOpened()) << "OpenCV cannot write FFV1";
    for (int t = 0; t < kFrames; ++t) writer.write(Pattern(t, kWidth, kHeight));
  }
  constexpr int kFirst = 2;
  auto source =
      VideoSource::Open(MakeCamera("cam0.mkv", kWidth, kHeight, v1::LINEAR, 0), dir.path(), kFirst, "scene.cameras[0]");
  ASSERT_TRUE(source.ok()) << source.status();
  auto probe = (*source)->Probe();
  ASSERT_TRUE(probe.ok()) << probe.status();
  EXPECT_EQ(probe->width, kWidth);
  EXPECT_EQ(probe->height, kHeight);
  EXPECT_EQ(probe->frame_count, kFrames - kFirst);
  // Forwards, with a skip, then backwards (reopens).
  for (int t : {0, 1, 3, 1, 0}) {
    auto frame = (*source)->ReadFrame(t);
    ASSERT_TRUE(frame.ok()) << frame.status();
    SCOPED_TRACE(t);
    ExpectEqualsBgr8(*frame, Pattern(kFirst + t, kWidth, kHeight));
  }
  auto past = (*source)->ReadFrame(kFrames - kFirst);
  EXPECT_EQ(past.status().code(), absl::StatusCode::kOutOfRange) << past.status();
  EXPECT_TRUE((*source)->ReadFrame(2).ok());  // usable after the end
}

TEST(VideoSourceTest, PngSequence8BitSrgb) {
  TempDir dir;
  std::filesystem::create_directories(dir / "cam");
  for (int t = 3; t < 7; ++t) {
    ASSERT_TRUE(cv::imwrite((dir / absl::StrFormat("cam/%04d.png", t)).string(), Pattern(t, 16, 8)));
  }
  auto source = VideoSource::Open(MakeCamera("cam/%04d.png", 16, 8, v1::SRGB, 8), dir.path(), 3, "scene.cameras[1]");
  ASSERT_TRUE(source.ok()) << source.status();
  auto probe = (*source)->Probe();
  ASSERT_TRUE(probe.ok()) << probe.status();
  EXPECT_EQ(probe->width, 16);
  EXPECT_EQ(probe->height, 8);
  EXPECT_EQ(probe->frame_count, 4);
  auto frame = (*source)->ReadFrame(1);
  ASSERT_TRUE(frame.ok()) << frame.status();
  const cv::Mat expected = Pattern(4, 16, 8);
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 16; ++x) {
      for (int c = 0; c < 3; ++c) {
        const float code = expected.at<cv::Vec3b>(y, x)[2 - c] / 255.0f;
        EXPECT_NEAR(frame->at<cv::Vec3f>(y, x)[c], SrgbToLinear(code), 1e-6f);
      }
    }
  }
  auto missing = (*source)->ReadFrame(4);
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound) << missing.status();
}

TEST(VideoSourceTest, PngSequence16BitLinear) {
  TempDir dir;
  cv::Mat image(4, 5, CV_16UC3);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 5; ++x) image.at<cv::Vec3w>(y, x) = cv::Vec3w(1000 * x, 300 * y + 7, 65535);
  }
  for (int t = 0; t < 2; ++t) ASSERT_TRUE(cv::imwrite((dir / absl::StrFormat("f%d.png", t)).string(), image));
  auto source = VideoSource::Open(MakeCamera("f%d.png", 5, 4, v1::LINEAR, 16), dir.path(), 0, "scene.cameras[0]");
  ASSERT_TRUE(source.ok()) << source.status();
  auto frame = (*source)->ReadFrame(1);
  ASSERT_TRUE(frame.ok()) << frame.status();
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 5; ++x) {
      const cv::Vec3f rgb = frame->at<cv::Vec3f>(y, x);
      EXPECT_FLOAT_EQ(rgb[0], 1.0f);
      EXPECT_FLOAT_EQ(rgb[1], (300 * y + 7) / 65535.0f);
      EXPECT_FLOAT_EQ(rgb[2], 1000 * x / 65535.0f);
    }
  }
  // The same files declared 8-bit: a clear error.
  auto wrong = VideoSource::Open(MakeCamera("f%d.png", 5, 4, v1::LINEAR, 8), dir.path(), 0, "scene.cameras[4]");
  ASSERT_TRUE(wrong.ok());
  auto bad = (*wrong)->ReadFrame(0);
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("scene.cameras[4].video"), std::string::npos) << bad.status();
  EXPECT_NE(bad.status().message().find("16-bit, expected 8-bit"), std::string::npos) << bad.status();
}

TEST(VideoSourceTest, ErrorsNameTheField) {
  TempDir dir;
  auto missing_video = VideoSource::Open(MakeCamera("nope.mkv", 4, 4, v1::SRGB, 0), dir.path(), 0, "scene.cameras[2]");
  EXPECT_EQ(missing_video.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(missing_video.status().message().find("scene.cameras[2].video.path"), std::string::npos)
      << missing_video.status();
  auto missing_frames =
      VideoSource::Open(MakeCamera("c/%04d.png", 4, 4, v1::SRGB, 0), dir.path(), 5, "scene.cameras[1]");
  EXPECT_EQ(missing_frames.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(missing_frames.status().message().find("0005.png"), std::string::npos) << missing_frames.status();

  // 16-bit frames must come as images: the FFmpeg backend decodes to 8 bits.
  testing::WriteText(dir / "v.mkv", "not really a video");
  auto deep_video = VideoSource::Open(MakeCamera("v.mkv", 4, 4, v1::SRGB, 16), dir.path(), 0, "scene.cameras[0]");
  EXPECT_EQ(deep_video.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(deep_video.status().message().find("scene.cameras[0].video.bit_depth"), std::string::npos)
      << deep_video.status();
  // A file FFmpeg cannot read.
  auto garbage = VideoSource::Open(MakeCamera("v.mkv", 4, 4, v1::SRGB, 8), dir.path(), 0, "scene.cameras[0]");
  EXPECT_EQ(garbage.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(garbage.status().message().find("scene.cameras[0].video.path: cannot open video"), std::string::npos)
      << garbage.status();

  // Wrong frame size from ReadFrame.
  ASSERT_TRUE(cv::imwrite((dir / "s0.png").string(), Pattern(0, 8, 6)));
  auto source = VideoSource::Open(MakeCamera("s%d.png", 16, 12, v1::SRGB, 0), dir.path(), 0, "scene.cameras[3]");
  ASSERT_TRUE(source.ok()) << source.status();
  auto frame = (*source)->ReadFrame(0);
  EXPECT_EQ(frame.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(frame.status().message().find("is 8x6, expected 16x12"), std::string::npos) << frame.status();
}

}  // namespace
TEST(VideoSourceTest, SaturationAndMask) {
  TempDir dir;
  // 16-bit: column 0 at the top code, column 1 at 60000, column 2 below.
  cv::Mat image(2, 3, CV_16UC3, cv::Scalar(100, 100, 100));
  for (int y = 0; y < 2; ++y) {
    image.at<cv::Vec3w>(y, 0)[1] = 65535;
    image.at<cv::Vec3w>(y, 1)[0] = 60000;
  }
  ASSERT_TRUE(cv::imwrite((dir / "f0.png").string(), image));
  cv::Mat mask(2, 3, CV_8UC1, cv::Scalar(255));
  mask.at<uint8_t>(1, 2) = 0;
  ASSERT_TRUE(cv::imwrite((dir / "mask.png").string(), mask));
  v1::Camera camera = MakeCamera("f%d.png", 3, 2, v1::LINEAR, 16);
  camera.mutable_video()->clear_saturation_level();  // default: 65535
  auto source = VideoSource::Open(camera, dir.path(), 0, "scene.cameras[0]");
  ASSERT_TRUE(source.ok()) << source.status();
  auto frame = (*source)->ReadFrame(0);
  ASSERT_TRUE(frame.ok()) << frame.status();
  EXPECT_EQ(frame->at<cv::Vec3f>(0, 0)[0], kSaturatedPixel);
  EXPECT_NEAR(frame->at<cv::Vec3f>(0, 1)[2], 60000 / 65535.0f, 1e-6f);
  camera.mutable_video()->set_saturation_level(60000);
  camera.mutable_video()->set_mask_path("mask.png");
  source = VideoSource::Open(camera, dir.path(), 0, "scene.cameras[0]");
  ASSERT_TRUE(source.ok()) << source.status();
  frame = (*source)->ReadFrame(0);
  ASSERT_TRUE(frame.ok()) << frame.status();
  EXPECT_EQ(frame->at<cv::Vec3f>(0, 1)[0], kSaturatedPixel);
  EXPECT_EQ(frame->at<cv::Vec3f>(1, 2)[0], kMaskedPixel);
  EXPECT_NEAR(frame->at<cv::Vec3f>(0, 2)[0], 100 / 65535.0f, 1e-6f);
}

TEST(VideoSourceTest, FrameSelectionReadsEveryStepthFile) {
  TempDir dir;
  for (int t = 0; t < 5; ++t)
    ASSERT_TRUE(cv::imwrite((dir / absl::StrFormat("f%d.png", t)).string(), Pattern(t, 4, 3)));
  FrameSelection selection;
  selection.first = 1;
  selection.step = 2;
  auto source =
      VideoSource::Open(MakeCamera("f%d.png", 4, 3, v1::LINEAR, 8), dir.path(), selection, 2, "scene.cameras[0]");
  ASSERT_TRUE(source.ok()) << source.status();
  auto probe = (*source)->Probe();
  ASSERT_TRUE(probe.ok()) << probe.status();
  EXPECT_EQ(probe->frame_count, 2);
  auto frame = (*source)->ReadFrame(1);
  ASSERT_TRUE(frame.ok()) << frame.status();
  ExpectEqualsBgr8(*frame, Pattern(3, 4, 3));
}

}  // namespace mvbrdf::scene
