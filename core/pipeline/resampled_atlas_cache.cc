#include "core/pipeline/resampled_atlas_cache.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"

namespace mvbrdf::pipeline {
namespace {

// pwrite / pread (`transfer`) of the whole range, through short transfers
// and EINTR.
template <typename Byte, typename Transfer>
bool WholeRange(Transfer transfer, int fd, Byte* p, size_t bytes, uint64_t offset) {
  while (bytes > 0) {
    const ssize_t n = transfer(fd, p, bytes, static_cast<off_t>(offset));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n;
    bytes -= static_cast<size_t>(n);
    offset += static_cast<uint64_t>(n);
  }
  return true;
}

bool WriteAt(int fd, const void* data, size_t bytes, uint64_t offset) {
  return WholeRange(::pwrite, fd, static_cast<const char*>(data), bytes, offset);
}

bool ReadAt(int fd, void* data, size_t bytes, uint64_t offset) {
  return WholeRange(::pread, fd, static_cast<char*>(data), bytes, offset);
}

bool AllZero(const cv::Vec4f& v) {
  uint32_t bits[4];
  std::memcpy(bits, &v, sizeof(bits));
  return (bits[0] | bits[1] | bits[2] | bits[3]) == 0;
}

}  // namespace

absl::StatusOr<std::unique_ptr<ResampledAtlasCache>> ResampledAtlasCache::Create(size_t budget_bytes,
                                                                                 const std::string& dir) {
  std::filesystem::path where = dir;
  if (dir.empty()) {
    MVBRDF_ASSIGN_OR_RETURN(where, TemporaryDirectory());
  }
  std::string name = (where / "mvbrdf-atlases-XXXXXX").string();
  const int fd = ::mkostemp(name.data(), O_CLOEXEC);
  if (fd < 0) {
    return absl::UnavailableError(absl::StrCat(name, ": cannot create a temporary file: ", std::strerror(errno)));
  }
  if (::unlink(name.c_str()) != 0) {
    const int unlink_error = errno;
    ::close(fd);
    return absl::UnavailableError(
        absl::StrCat(name, ": cannot unlink the temporary file: ", std::strerror(unlink_error)));
  }
  std::error_code error;
  const std::filesystem::space_info space = std::filesystem::space(where, error);
  if (!error) budget_bytes = std::min<size_t>(budget_bytes, static_cast<size_t>(space.available / 2));
  return std::unique_ptr<ResampledAtlasCache>(new ResampledAtlasCache(fd, budget_bytes));
}

ResampledAtlasCache::~ResampledAtlasCache() { ::close(fd_); }

size_t ResampledAtlasCache::budget_left() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return failed_ ? 0 : budget_bytes_ - bytes_;
}

size_t ResampledAtlasCache::bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return bytes_;
}

size_t ResampledAtlasCache::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return entries_.size();
}

bool ResampledAtlasCache::Contains(int t, int camera, const std::string& key) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = entries_.find({t, camera});
  return it != entries_.end() && it->second.key == key;
}

std::optional<ResampledAtlasCache::Kept> ResampledAtlasCache::Find(int t, int camera, const std::string& key) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = entries_.find({t, camera});
  if (it == entries_.end() || it->second.key != key) return std::nullopt;
  const Entry& e = it->second;
  std::vector<uint32_t>& runs = runs_;
  std::vector<cv::Vec4f>& texels = texels_;
  runs.resize(2 * static_cast<size_t>(e.runs));
  texels.resize(e.texels);
  const size_t run_bytes = runs.size() * sizeof(uint32_t);
  if (!ReadAt(fd_, runs.data(), run_bytes, e.offset) ||
      !ReadAt(fd_, texels.data(), texels.size() * sizeof(cv::Vec4f), e.offset + run_bytes)) {
    return std::nullopt;  // an I/O error: the caller's fallback (ResampledAtlas resamples again)
  }
  Kept kept;
  kept.atlas = cv::Mat(e.rows, e.cols, CV_32FC4, cv::Scalar::all(0));
  kept.refused = e.refused;
  cv::Vec4f* out = kept.atlas.ptr<cv::Vec4f>();
  size_t next = 0;
  for (size_t r = 0; r < e.runs; ++r) {
    std::copy_n(texels.begin() + static_cast<std::ptrdiff_t>(next), runs[2 * r + 1], out + runs[2 * r]);
    next += runs[2 * r + 1];
  }
  return kept;
}

bool ResampledAtlasCache::Keep(int t, int camera, const std::string& key, const cv::Mat& atlas,
                               const resample::Resampler::RefusedObservations& refused) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (failed_ || entries_.count({t, camera}) != 0 || atlas.type() != CV_32FC4 || !atlas.isContinuous() ||
      atlas.empty()) {
    return false;
  }
  // Runs of texels that are not all zero (a texel no camera sees is zero).
  std::vector<uint32_t>& runs = runs_;
  std::vector<cv::Vec4f>& texels = texels_;
  runs.clear();
  texels.clear();
  const cv::Vec4f* in = atlas.ptr<cv::Vec4f>();
  const size_t total = atlas.total();
  for (size_t i = 0; i < total;) {
    if (AllZero(in[i])) {
      ++i;
      continue;
    }
    const size_t begin = i;
    while (i < total && !AllZero(in[i])) texels.push_back(in[i++]);
    runs.push_back(static_cast<uint32_t>(begin));
    runs.push_back(static_cast<uint32_t>(i - begin));
  }
  const size_t run_bytes = runs.size() * sizeof(uint32_t);
  const size_t texel_bytes = texels.size() * sizeof(cv::Vec4f);
  if (run_bytes + texel_bytes > budget_bytes_ - bytes_) return false;
  Entry e;
  e.key = key;
  e.rows = atlas.rows;
  e.cols = atlas.cols;
  e.offset = bytes_;
  e.runs = static_cast<uint32_t>(runs.size() / 2);
  e.texels = texels.size();
  e.refused = refused;
  if (!WriteAt(fd_, runs.data(), run_bytes, e.offset) ||
      !WriteAt(fd_, texels.data(), texel_bytes, e.offset + run_bytes)) {
    failed_ = true;  // the disk is full, say: the passes resample what is not kept
    return false;
  }
  bytes_ += run_bytes + texel_bytes;
  entries_.emplace(std::make_pair(t, camera), std::move(e));
  return true;
}

}  // namespace mvbrdf::pipeline
