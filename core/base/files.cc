#include "core/base/files.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>

#include "absl/strings/str_cat.h"

namespace mvbrdf {

absl::StatusOr<std::string> ReadFileToString(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat(path.string(), ": file not found"));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::PermissionDeniedError(absl::StrCat(path.string(), ": cannot open for reading"));
  std::ostringstream out;
  out << in.rdbuf();
  if (in.bad()) return absl::DataLossError(absl::StrCat(path.string(), ": read failed"));
  return std::move(out).str();
}

absl::Status WriteStringToFile(const std::filesystem::path& path, absl::string_view contents) {
  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  if (ec) return ErrnoStatus(ec.value(), "cannot create directory", path.parent_path().string());
  const std::filesystem::path tmp = path.string() + ".tmp";
  {
    errno = 0;  // what a failed write leaves names the cause
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return absl::PermissionDeniedError(absl::StrCat(tmp.string(), ": cannot open for writing"));
    out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
    out.flush();
    if (!out) return ErrnoStatus(errno != 0 ? errno : EIO, "write failed", tmp.string());
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) return ErrnoStatus(ec.value(), "cannot rename temporary file", path.string());
  return absl::OkStatus();
}

namespace {

// Counts integer conversions in a printf pattern; returns -1 on a conversion
// that is not an integer one.
int CountIntegerConversions(absl::string_view pattern) {
  int count = 0;
  for (size_t i = 0; i < pattern.size(); ++i) {
    if (pattern[i] != '%') continue;
    if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
      ++i;
      continue;
    }
    size_t j = i + 1;
    while (j < pattern.size() && (pattern[j] == '0' || pattern[j] == '-' || pattern[j] == '+' || pattern[j] == ' ')) ++j;
    while (j < pattern.size() && pattern[j] >= '0' && pattern[j] <= '9') ++j;
    if (j >= pattern.size() || (pattern[j] != 'd' && pattern[j] != 'i' && pattern[j] != 'u')) return -1;
    ++count;
    i = j;
  }
  return count;
}

}  // namespace

bool IsFramePattern(absl::string_view pattern) { return CountIntegerConversions(pattern) == 1; }

absl::Status ValidateFramePattern(absl::string_view pattern, absl::string_view field) {
  const int n = CountIntegerConversions(pattern);
  if (n < 0 || n > 1) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": expected at most one integer conversion such as %04d, got \"",
                                                   pattern, "\""));
  }
  return absl::OkStatus();
}

std::string FormatFramePattern(absl::string_view pattern, int index) {
  if (!IsFramePattern(pattern)) return std::string(pattern);
  const std::string p(pattern);
  const int size = std::snprintf(nullptr, 0, p.c_str(), index);
  std::string out(static_cast<size_t>(size) + 1, '\0');
  std::snprintf(out.data(), out.size(), p.c_str(), index);
  out.resize(static_cast<size_t>(size));
  return out;
}

std::filesystem::path ResolvePath(const std::filesystem::path& base_dir, absl::string_view relative) {
  std::filesystem::path p{std::string(relative)};
  if (p.is_absolute()) return p;
  return base_dir / p;
}

absl::Status ErrnoStatus(int error, absl::string_view what, absl::string_view path) {
  const std::string message = absl::StrCat(path, ": ", what, ": ", std::strerror(error));
  if (error == ENOSPC || error == EDQUOT || error == EFBIG) return absl::ResourceExhaustedError(message);
  if (error == ENOENT) return absl::NotFoundError(message);
  if (error == EACCES || error == EPERM || error == EROFS) return absl::PermissionDeniedError(message);
  // The file system failed under us (exit 4, not an internal error).
  if (error == EIO || error == EMFILE || error == ENFILE) return absl::UnavailableError(message);
  return absl::InternalError(message);
}

absl::Status WriteAllToFd(int fd, absl::string_view bytes, absl::string_view path) {
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd, bytes.data(), bytes.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return ErrnoStatus(errno, "write failed", path);
    if (n == 0) return ErrnoStatus(EIO, "write failed", path);
    bytes.remove_prefix(static_cast<size_t>(n));
  }
  return absl::OkStatus();
}

}  // namespace mvbrdf
