#include "core/image/exr.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

namespace mvbrdf::image {
namespace {

constexpr float kHalfRelativeTolerance = 1e-3f;  // half floats keep ~11 bits of mantissa

std::filesystem::path TempFile(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "mvbrdf_exr_test";
  std::filesystem::create_directories(dir);
  return dir / name;
}

cv::Mat Ramp(int channels) {
  cv::Mat m(5, 7, CV_32FC(channels));
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x)
      for (int c = 0; c < channels; ++c) m.ptr<float>(y)[x * channels + c] = 0.01f * (y * 100 + x * 10 + c) + 1e-7f * x;
  return m;
}

TEST(ExrTest, FloatRoundTripIsExactForEveryChannelCount) {
  for (int channels : {1, 3, 4}) {
    const cv::Mat image = Ramp(channels);
    const auto file = TempFile("ramp" + std::to_string(channels) + ".exr");
    ASSERT_TRUE(WriteExr(file, image).ok());
    auto back = ReadExr(file);
    ASSERT_TRUE(back.ok()) << back.status();
    ASSERT_EQ(back->image.type(), image.type());
    EXPECT_EQ(cv::norm(back->image, image, cv::NORM_INF), 0.0) << channels;
  }
}

TEST(ExrTest, HalfRoundTripIsClose) {
  const cv::Mat image = Ramp(4);
  const auto file = TempFile("half.exr");
  ExrOptions options;
  options.half = true;
  const absl::Status written = WriteExr(file, image, options);
  ASSERT_TRUE(written.ok()) << written;
  auto back = ReadExr(file);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->channel_names, (std::vector<std::string>{"R", "G", "B", "A"}));
  for (int i = 0; i < static_cast<int>(image.total()) * 4; ++i) {
    const float a = image.ptr<float>()[i], b = back->image.ptr<float>()[i];
    EXPECT_NEAR(a, b, kHalfRelativeTolerance * std::abs(a) + 1e-6f);
  }
}

TEST(ExrTest, NamedChannelsAndIntegerMasks) {
  cv::Mat two(3, 3, CV_32FC2, cv::Scalar(1.5, -2.0));
  ExrOptions options;
  options.channel_names = {"ks", "ke"};
  ASSERT_TRUE(WriteExr(TempFile("named.exr"), two, options).ok());
  auto back = ReadExr(TempFile("named.exr"));
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->image.channels(), 2);
  // Unknown names keep EXR's alphabetical order: ke, ks.
  EXPECT_EQ(back->channel_names, (std::vector<std::string>{"ke", "ks"}));
  EXPECT_FLOAT_EQ(back->image.at<cv::Vec2f>(1, 1)[0], -2.0f);

  cv::Mat ids(4, 4, CV_32SC1, cv::Scalar(-1));
  ids.at<int32_t>(2, 3) = 12345;
  ASSERT_TRUE(WriteExr(TempFile("ids.exr"), ids).ok());
  auto ids_back = ReadExr(TempFile("ids.exr"));
  ASSERT_TRUE(ids_back.ok()) << ids_back.status();
  ASSERT_EQ(ids_back->image.type(), CV_32SC1);
  EXPECT_EQ(ids_back->image.at<int32_t>(2, 3), 12345);
  EXPECT_EQ(ids_back->image.at<int32_t>(0, 0), -1);

  // Several named UINT channels (a shadow atlas of 40 lights: CV_16UC3);
  // without names they are refused.
  cv::Mat bits(4, 4, CV_16UC3, cv::Scalar(1, 2, 0x80));
  bits.at<cv::Vec<uint16_t, 3>>(3, 1) = {0xffff, 0, 7};
  ExrOptions named;
  named.channel_names = {"lights0000-0015", "lights0016-0031", "lights0032-0047"};
  ASSERT_TRUE(WriteExr(TempFile("bits.exr"), bits, named).ok());
  EXPECT_FALSE(WriteExr(TempFile("bits_unnamed.exr"), bits).ok());
  auto bits_back = ReadExr(TempFile("bits.exr"));
  ASSERT_TRUE(bits_back.ok()) << bits_back.status();
  ASSERT_EQ(bits_back->image.type(), CV_32SC3);
  EXPECT_EQ(bits_back->channel_names, named.channel_names);
  EXPECT_EQ(bits_back->image.at<cv::Vec3i>(0, 0), cv::Vec3i(1, 2, 0x80));
  EXPECT_EQ(bits_back->image.at<cv::Vec3i>(3, 1), cv::Vec3i(0xffff, 0, 7));
}

TEST(ExrTest, ErrorsNameTheFile) {
  EXPECT_EQ(ReadExr(TempFile("missing.exr")).status().code(), absl::StatusCode::kNotFound);
  const auto junk = TempFile("junk.exr");
  cv::imwrite(TempFile("junk.png").string(), cv::Mat(2, 2, CV_8UC3, cv::Scalar::all(9)));
  std::filesystem::copy_file(TempFile("junk.png"), junk, std::filesystem::copy_options::overwrite_existing);
  const absl::Status s = ReadExr(junk).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kDataLoss);
  EXPECT_NE(s.message().find("junk.exr"), std::string::npos);
  EXPECT_EQ(WriteExr(TempFile("bad.exr"), cv::Mat(2, 2, CV_8UC3)).code(), absl::StatusCode::kInvalidArgument);
}

TEST(ExrTest, PreviewEncodesSrgbAndAlpha) {
  cv::Mat rgba(1, 2, CV_32FC4);
  rgba.at<cv::Vec4f>(0, 0) = {0.21586f, 0.0f, 1.0f, 1.0f};  // sRGB 128, 0, 255
  rgba.at<cv::Vec4f>(0, 1) = {0.0f, 0.0f, 0.0f, 0.0f};      // invalid: transparent
  const auto file = TempFile("preview.png");
  ASSERT_TRUE(WritePngPreview(file, rgba).ok());
  const cv::Mat png = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(png.type(), CV_8UC4);
  EXPECT_EQ(png.at<cv::Vec4b>(0, 0), cv::Vec4b(255, 0, 128, 255));  // BGRA
  EXPECT_EQ(png.at<cv::Vec4b>(0, 1)[3], 0);
}

}  // namespace
}  // namespace mvbrdf::image
