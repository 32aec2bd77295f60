#include "core/image/exr.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
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

}  // namespace

absl::Status WriteExr(const std::filesystem::path& file, const cv::Mat& image, const ExrOptions& options) {
  const int channels = image.channels();
  const bool is_uint = image.depth() == CV_16U || image.depth() == CV_32S;
  if (image.empty() || !(image.depth() == CV_32F || (is_uint && channels == 1)) || channels > 4) {
    return absl::InvalidArgumentError(absl::StrCat(file.string(), ": WriteExr takes CV_32F with 1-4 channels or a "
                                                   "single-channel CV_16U/CV_32S image"));
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
  std::error_code ec;
  if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path(), ec);
  const std::filesystem::path tmp = file.string() + ".tmp";
  try {
    Imf::OutputFile out(tmp.c_str(), header);
    out.setFrameBuffer(frame_buffer);
    out.writePixels(image.rows);
  } catch (const std::exception& e) {
    std::filesystem::remove(tmp, ec);
    // The file system's failure (exit 4), not the data's.
    const std::string message = absl::StrCat(file.string(), ": cannot write OpenEXR: ", e.what());
    if (absl::StrContains(e.what(), "No space left") || absl::StrContains(e.what(), "quota")) {
      return absl::ResourceExhaustedError(message);
    }
    return absl::UnavailableError(message);
  }
  std::filesystem::rename(tmp, file, ec);
  if (ec) return ErrnoStatus(ec.value(), "cannot rename temporary file", file.string());
  return absl::OkStatus();
}

absl::StatusOr<ExrImage> ReadExr(const std::filesystem::path& file) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) return absl::NotFoundError(absl::StrCat(file.string(), ": file not found"));
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
    if (names.empty() || names.size() > 4 || (has_uint && names.size() != 1)) {
      return absl::InvalidArgumentError(absl::StrCat(file.string(), ": expected 1-4 float channels or one uint channel, got ",
                                                     names.size(), " channels"));
    }
    ExrImage result;
    result.channel_names = names;
    const int channels = static_cast<int>(names.size());
    result.image = has_uint ? cv::Mat(height, width, CV_32SC1) : cv::Mat(height, width, CV_32FC(channels));
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

absl::Status WritePngPreview(const std::filesystem::path& file, const cv::Mat& linear, float gain) {
  const int channels = linear.channels();
  if (linear.depth() != CV_32F || (channels != 1 && channels != 3 && channels != 4)) {
    return absl::InvalidArgumentError(absl::StrCat(file.string(), ": a preview takes CV_32F with 1, 3 or 4 channels"));
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
  std::error_code ec;
  if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path(), ec);
  if (!cv::imwrite(file.string(), out)) return absl::DataLossError(absl::StrCat(file.string(), ": cannot write PNG"));
  return absl::OkStatus();
}

}  // namespace mvbrdf::image
