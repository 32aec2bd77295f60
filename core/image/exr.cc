#include "core/image/exr.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <opencv2/imgcodecs.hpp>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/scene/video_source.h"

namespace mvbrdf::image {
namespace {

std::vector<std::string> DefaultNames(int channels) {
  switch (channels) {
    case 1: return {"Y"};
    case 3: return {"R", "G", "B"};
    case 4: return {"R", "G", "B", "A"};
    default: {
      std::vector<std::string> names;
      for (int c = 0; c < channels; ++c) names.push_back(absl::StrCat("C", c));
      return names;
    }
  }
}

int ChannelRank(const std::string& name) {
  static const std::map<std::string, int> kRank = {{"R", 0}, {"G", 1}, {"B", 2}, {"A", 3}, {"Y", 4}};
  const auto it = kRank.find(name);
  return it == kRank.end() ? 5 : it->second;
}

// An OpenEXR output stream into memory.
class MemoryOStream : public Imf::OStream {
 public:
  explicit MemoryOStream(const std::string& name) : Imf::OStream(name.c_str()) {}
  void write(const char c[], int n) override {
    if (position_ + static_cast<size_t>(n) > bytes_.size()) bytes_.resize(position_ + static_cast<size_t>(n));
    std::memcpy(bytes_.data() + position_, c, static_cast<size_t>(n));
    position_ += static_cast<size_t>(n);
  }
  uint64_t tellp() override { return position_; }
  void seekp(uint64_t pos) override { position_ = static_cast<size_t>(pos); }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
  size_t position_ = 0;
};

}  // namespace

absl::Status WriteExr(const std::filesystem::path& file, const cv::Mat& image, const ExrOptions& options) {
  const int channels = image.channels();
  const bool is_uint = image.depth() == CV_16U || image.depth() == CV_32S;
  // Integer images: one channel, or several with their names (the shadow
  // atlas of more than 16 lights, core/samples/assemble.h).
  const bool uint_ok = is_uint && (channels == 1 || (static_cast<int>(options.channel_names.size()) == channels));
  if (image.empty() || !(image.depth() == CV_32F || uint_ok) || (!is_uint && channels > 4)) {
    return absl::InvalidArgumentError(absl::StrCat(file.string(),
                                                   ": WriteExr takes CV_32F with 1-4 channels or a "
                                                   "CV_16U/CV_32S image (one channel, or named channels)"));
  }
  const std::vector<std::string> names =
      options.channel_names.empty() ? DefaultNames(channels) : options.channel_names;
  if (static_cast<int>(names.size()) != channels) {
    return absl::InvalidArgumentError(absl::StrCat(file.string(), ": ", names.size(), " channel names for ", channels,
                                                   " channels"));
  }
  cv::Mat data = image;
  if (image.depth() == CV_16U) image.convertTo(data, CV_32S);
  // OpenEXR writes a slice only in its channel's own type: convert to IEEE
  // half (OpenCV's CV_16F has the same bits as Imath::half) here.
  const bool half = !is_uint && options.half;
  if (half) image.convertTo(data, CV_16F);
  if (!data.isContinuous()) data = data.clone();

  const Imf::PixelType pixel_type = is_uint ? Imf::UINT : half ? Imf::HALF : Imf::FLOAT;
  Imf::Header header(image.cols, image.rows);
  header.compression() = Imf::ZIP_COMPRESSION;
  Imf::FrameBuffer frame_buffer;
  const size_t element = half ? 2 : sizeof(float);
  const size_t pixel_stride = element * static_cast<size_t>(channels);
  for (int c = 0; c < channels; ++c) {
    header.channels().insert(names[c].c_str(), Imf::Channel(pixel_type));
    frame_buffer.insert(names[c].c_str(),
                        Imf::Slice(pixel_type, reinterpret_cast<char*>(data.data) + c * element, pixel_stride,
                                   pixel_stride * static_cast<size_t>(image.cols)));
  }
  // Encoded in memory, then written by WriteStringToFile: every write checked,
  // to a temporary renamed into place (OpenEXR's own file stream loses write
  // errors in its destructor, so a full disk left a truncated file).
  MemoryOStream stream(file.string());
  try {
    Imf::OutputFile out(stream, header);
    out.setFrameBuffer(frame_buffer);
    out.writePixels(image.rows);
  } catch (const std::exception& e) {
    return absl::InternalError(absl::StrCat(file.string(), ": cannot encode OpenEXR: ", e.what()));
  }
  return WriteStringToFile(file, stream.bytes());
}

absl::StatusOr<ExrImage> ReadExr(const std::filesystem::path& file) {
  if (const std::string why = WhyNotRegularFile(file); !why.empty()) {
    return NotRegularFileError(why, absl::StrCat(file.string(), ": file ", why));
  }
  try {
    Imf::InputFile in(file.c_str());
    const Imath::Box2i window = in.header().dataWindow();
    const int width = window.max.x - window.min.x + 1;
    const int height = window.max.y - window.min.y + 1;
    std::vector<std::string> names;
    bool has_uint = false;
    for (auto it = in.header().channels().begin(); it != in.header().channels().end(); ++it) {
      names.emplace_back(it.name());
      has_uint = has_uint || it.channel().type == Imf::UINT;
    }
    std::stable_sort(names.begin(), names.end(),
                     [](const std::string& a, const std::string& b) { return ChannelRank(a) < ChannelRank(b); });
    bool all_uint = true;
    for (auto it = in.header().channels().begin(); it != in.header().channels().end(); ++it) {
      all_uint = all_uint && it.channel().type == Imf::UINT;
    }
    if (names.empty() || (!has_uint && names.size() > 4) || (has_uint && (!all_uint || names.size() > CV_CN_MAX))) {
      return absl::InvalidArgumentError(absl::StrCat(
          file.string(), ": expected 1-4 float channels or uint channels, got ", names.size(), " channels"));
    }
    ExrImage result;
    result.channel_names = names;
    const int channels = static_cast<int>(names.size());
    result.image = has_uint ? cv::Mat(height, width, CV_32SC(channels)) : cv::Mat(height, width, CV_32FC(channels));
    const size_t element = sizeof(float);
    const size_t pixel_stride = element * static_cast<size_t>(channels);
    Imf::FrameBuffer frame_buffer;
    // Offset the base pointer so that the data window's origin maps to row 0.
    char* base = reinterpret_cast<char*>(result.image.data) -
                 static_cast<ptrdiff_t>(window.min.x) * static_cast<ptrdiff_t>(pixel_stride) -
                 static_cast<ptrdiff_t>(window.min.y) * static_cast<ptrdiff_t>(pixel_stride) * width;
    for (int c = 0; c < channels; ++c) {
      frame_buffer.insert(names[c].c_str(), Imf::Slice(has_uint ? Imf::UINT : Imf::FLOAT, base + c * element,
                                                       pixel_stride, pixel_stride * static_cast<size_t>(width)));
    }
    in.setFrameBuffer(frame_buffer);
    in.readPixels(window.min.y, window.max.y);
    return result;
  } catch (const std::exception& e) {
    return absl::DataLossError(absl::StrCat(file.string(), ": not a readable OpenEXR file: ", e.what()));
  }
}

absl::StatusOr<std::string> EncodePngPreview(const cv::Mat& linear, float gain) {
  const int channels = linear.channels();
  if (linear.depth() != CV_32F || (channels != 1 && channels != 3 && channels != 4)) {
    return absl::InvalidArgumentError("a preview takes CV_32F with 1, 3 or 4 channels");
  }
  cv::Mat out(linear.rows, linear.cols, CV_8UC(channels == 1 ? 1 : channels));
  const auto encode = [gain](float v) {
    const float lin = std::clamp(v * gain, 0.0f, 1.0f);
    return static_cast<uint8_t>(std::lround(255.0f * scene::LinearToSrgb(lin)));
  };
  for (int y = 0; y < linear.rows; ++y) {
    const float* in = linear.ptr<float>(y);
    uint8_t* o = out.ptr<uint8_t>(y);
    for (int x = 0; x < linear.cols; ++x) {
      const float* px = in + static_cast<ptrdiff_t>(x) * channels;
      uint8_t* q = o + static_cast<ptrdiff_t>(x) * channels;
      if (channels == 1) {
        q[0] = encode(px[0]);
        continue;
      }
      // RGB(A) in, BGR(A) out for OpenCV.
      q[0] = encode(px[2]);
      q[1] = encode(px[1]);
      q[2] = encode(px[0]);
      if (channels == 4) q[3] = static_cast<uint8_t>(std::lround(255.0f * std::clamp(px[3], 0.0f, 1.0f)));
    }
  }
  return EncodePng(out);
}

absl::StatusOr<std::string> EncodePng(const cv::Mat& image) {
  std::vector<uchar> bytes;
  try {
    if (!cv::imencode(".png", image, bytes)) return absl::InternalError("cannot encode PNG");
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("cannot encode PNG: ", e.what()));
  }
  return std::string(bytes.begin(), bytes.end());
}

absl::Status WritePngPreview(const std::filesystem::path& file, const cv::Mat& linear, float gain) {
  absl::StatusOr<std::string> png = EncodePngPreview(linear, gain);
  if (!png.ok()) return absl::Status(png.status().code(), absl::StrCat(file.string(), ": ", png.status().message()));
  return WriteStringToFile(file, *png);
}

}  // namespace mvbrdf::image
