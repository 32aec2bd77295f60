#include "core/base/files.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>

#include "absl/strings/str_cat.h"

namespace mvbrdf {

std::string WhyNotRegularFile(const std::filesystem::path& path) {
  std::error_code ec;
  const std::filesystem::file_status st = std::filesystem::status(path, ec);
  switch (st.type()) {
    case std::filesystem::file_type::regular:
      return "";
    case std::filesystem::file_type::not_found:
      return "not found";
    case std::filesystem::file_type::directory:
      return "is a directory";
    case std::filesystem::file_type::fifo:
      return "is a FIFO, not a regular file";
    case std::filesystem::file_type::socket:
      return "is a socket, not a regular file";
    case std::filesystem::file_type::character:
      return "is a character device, not a regular file";
    case std::filesystem::file_type::block:
      return "is a block device, not a regular file";
    default:
      break;
  }
  if (ec) return absl::StrCat("cannot be examined: ", ec.message());
  return "is not a regular file";
}

absl::Status NotRegularFileError(absl::string_view why, absl::string_view message) {
  if (why == "not found") return absl::NotFoundError(message);
  return absl::InvalidArgumentError(message);
}

absl::StatusOr<std::string> ReadFileToString(const std::filesystem::path& path) {
  if (const std::string why = WhyNotRegularFile(path); !why.empty()) {
    return NotRegularFileError(why, absl::StrCat(ElideForMessage(path.string(), kMaxShownPathChars), ": file ", why));
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
  // A temporary of its own beside the file (two writers of one file never
  // share it), every byte checked, then renamed over the file.
  std::string tmp = path.string() + ".tmp-XXXXXX";
  const int fd = ::mkstemp(tmp.data());
  if (fd < 0) return ErrnoStatus(errno, "cannot create a temporary file", tmp);
  ::fchmod(fd, 0644);  // mkstemp creates 0600
  absl::Status written = WriteAllToFd(fd, contents, path.string());
  if (::close(fd) != 0 && written.ok()) written = ErrnoStatus(errno, "write failed", path.string());
  if (written.ok() && ::rename(tmp.c_str(), path.c_str()) != 0) {
    written = ErrnoStatus(errno, "cannot rename the temporary file over it", path.string());
  }
  if (!written.ok()) ::unlink(tmp.c_str());
  return written;
}

absl::Status CopyFileReplacing(const std::filesystem::path& from, const std::filesystem::path& to) {
  const int in = ::open(from.c_str(), O_RDONLY | O_CLOEXEC);
  if (in < 0) return ErrnoStatus(errno, "cannot open", from.string());
  std::error_code ec;
  if (to.has_parent_path()) std::filesystem::create_directories(to.parent_path(), ec);
  if (ec) {
    ::close(in);
    return ErrnoStatus(ec.value(), "cannot create directory", to.parent_path().string());
  }
  std::string tmp = to.string() + ".tmp-XXXXXX";
  const int out = ::mkstemp(tmp.data());
  if (out < 0) {
    const int error = errno;
    ::close(in);
    return ErrnoStatus(error, "cannot create a temporary file", tmp);
  }
  ::fchmod(out, 0644);  // mkstemp creates 0600
  absl::Status copied;
  std::string buffer(1 << 20, '\0');
  while (copied.ok()) {
    const ssize_t n = ::read(in, buffer.data(), buffer.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) copied = ErrnoStatus(errno, "read failed", from.string());
    if (n <= 0) break;
    copied = WriteAllToFd(out, absl::string_view(buffer.data(), static_cast<size_t>(n)), to.string());
  }
  ::close(in);
  if (::close(out) != 0 && copied.ok()) copied = ErrnoStatus(errno, "write failed", to.string());
  if (copied.ok() && ::rename(tmp.c_str(), to.c_str()) != 0) {
    copied = ErrnoStatus(errno, "cannot rename the temporary file over it", to.string());
  }
  if (!copied.ok()) ::unlink(tmp.c_str());
  return copied;
}

namespace {

// Counts integer conversions in a printf pattern; returns -1 on a conversion
// that is not an accepted frame conversion ("%d", "%i", "%u", or one of them
// zero-padded to a width of at most kMaxFrameDigits, "%04d"), -2 on one of
// those with a width over kMaxFrameDigits.
int CountIntegerConversions(absl::string_view pattern) {
  int count = 0;
  for (size_t i = 0; i < pattern.size(); ++i) {
    if (pattern[i] != '%') continue;
    if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
      ++i;
      continue;
    }
    size_t j = i + 1;
    const bool zero_padded = j < pattern.size() && pattern[j] == '0';
    if (zero_padded) ++j;
    const size_t digits_begin = j;
    while (j < pattern.size() && pattern[j] >= '0' && pattern[j] <= '9') ++j;
    const size_t digits = j - digits_begin;
    if (j >= pattern.size() || (pattern[j] != 'd' && pattern[j] != 'i' && pattern[j] != 'u')) return -1;
    // Compared as text: "%0999999999999d" must not overflow an int.
    static_assert(kMaxFrameDigits <= 9, "one digit of width");
    if (digits > 1 || (digits == 1 && pattern[digits_begin] - '0' > kMaxFrameDigits)) return -2;
    if (digits == 1 && pattern[digits_begin] == '0') return -1;  // "%00d"
    if (zero_padded != (digits > 0)) return -1;                  // "%5d" pads with spaces, "%0d" means nothing
    ++count;
    i = j;
  }
  return count;
}

}  // namespace

bool IsFramePattern(absl::string_view pattern) { return CountIntegerConversions(pattern) == 1; }

absl::Status ValidateFramePattern(absl::string_view pattern, absl::string_view field) {
  const int n = CountIntegerConversions(pattern);
  if (n == -2) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": a frame number is at most ", kMaxFrameDigits,
                                                   " digits wide (%d or %01d to %0", kMaxFrameDigits, "d), got \"",
                                                   ElideForMessage(pattern), "\""));
  }
  if (n < 0 || n > 1) {
    return absl::InvalidArgumentError(absl::StrCat(field,
                                                   ": expected at most one frame conversion, %d or zero-padded such as "
                                                   "%04d (no other conversion; %% is a percent sign), got \"",
                                                   ElideForMessage(pattern), "\""));
  }
  return absl::OkStatus();
}

std::string ElideForMessage(absl::string_view text, size_t max_chars) {
  if (text.size() <= max_chars) return std::string(text);
  return absl::StrCat(text.substr(0, max_chars), "... (", text.size(), " characters)");
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

absl::StatusOr<std::filesystem::path> TemporaryDirectory() {
  std::error_code error;
  const std::filesystem::path dir = std::filesystem::temp_directory_path(error);
  if (!error) return dir;
  const char* tmpdir = std::getenv("TMPDIR");
  return absl::UnavailableError(absl::StrCat(
      "the directory for temporary files (TMPDIR=", tmpdir != nullptr ? ElideForMessage(tmpdir, kMaxShownPathChars) : "",
      ", else TMP, TEMP, TEMPDIR or /tmp): ", error.message(), "; set TMPDIR to an existing, writable directory"));
}

}  // namespace mvbrdf
