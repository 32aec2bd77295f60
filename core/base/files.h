// File-system helpers: whole-file I/O and frame-numbered path patterns.
#ifndef MVBRDF_CORE_BASE_FILES_H_
#define MVBRDF_CORE_BASE_FILES_H_

#include <filesystem>
#include <string>
#include "absl/strings/string_view.h"

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace mvbrdf {

// Why `path` (symlinks followed) cannot be read as a file: "" for a regular
// file, else "not found", "is a directory", "is a FIFO, not a regular file",
// "is a character device, not a regular file" (/dev/zero), ...
std::string WhyNotRegularFile(const std::filesystem::path& path);
// The status for a WhyNotRegularFile reason `why`: NOT_FOUND for "not found",
// else INVALID_ARGUMENT; `message` is the whole message.
absl::Status NotRegularFileError(absl::string_view why, absl::string_view message);

// Reads a whole file. NOT_FOUND names the path when it does not exist;
// directories, FIFOs and devices are refused (WhyNotRegularFile).
absl::StatusOr<std::string> ReadFileToString(const std::filesystem::path& path);

// Writes a whole file, creating parent directories. Writes to a temporary
// file of its own beside it, checks every write and the close, and renames,
// so a reader never sees a half-written file and a full disk is an error
// (RESOURCE_EXHAUSTED, see ErrnoStatus) with nothing left behind.
absl::Status WriteStringToFile(const std::filesystem::path& path, absl::string_view contents);

// Copies the regular file `from` to `to` the way WriteStringToFile writes
// (parent directories created, a temporary of its own beside `to`, every read
// and write checked, renamed over `to`), streaming: a full disk leaves
// neither a truncated `to` nor the temporary. Errors as ErrnoStatus.
absl::Status CopyFileReplacing(const std::filesystem::path& from, const std::filesystem::path& to);

// The status of a failed system call on `path`, from its errno `error`:
// "path: what: strerror(error)", RESOURCE_EXHAUSTED for a full disk, quota or
// file size limit, NOT_FOUND, PERMISSION_DENIED (also a read-only file
// system), UNAVAILABLE for I/O errors and no free descriptors, else INTERNAL.
absl::Status ErrnoStatus(int error, absl::string_view what, absl::string_view path);

// Writes all of `bytes` to the descriptor `fd` (short writes and EINTR
// retried). Errors as ErrnoStatus, naming `path`.
absl::Status WriteAllToFd(int fd, absl::string_view bytes, absl::string_view path);

// The directory for temporary files (std::filesystem::temp_directory_path:
// TMPDIR, else TMP, TEMP, TEMPDIR, else /tmp), checked to be a directory. UNAVAILABLE naming TMPDIR
// when it is not (a TMPDIR that does not exist made std::filesystem throw).
absl::StatusOr<std::filesystem::path> TemporaryDirectory();

// The widest frame number a pattern may ask for ("%09d"): a wider one only
// pads (an int has 10 digits), and "%999999999d" would ask for a 1 GB name.
constexpr int kMaxFrameDigits = 9;

// True when `pattern` holds exactly one frame conversion: "%d", "%i", "%u"
// or one of them zero-padded ("%04d", at most kMaxFrameDigits wide), e.g.
// "mesh_%04d.obj".
bool IsFramePattern(absl::string_view pattern);

// Checks that `pattern` is usable as a frame pattern: at most one frame
// conversion as IsFramePattern accepts, no other conversions ("%%" is a
// literal percent sign; "%5d", "%-4d", "%s" and widths over kMaxFrameDigits
// are errors). `field` names the pattern in the error, e.g. "scene.mesh.path".
absl::Status ValidateFramePattern(absl::string_view pattern, absl::string_view field);

// Expands a frame pattern with `index`; returns `pattern` unchanged when it
// holds no conversion. Requires ValidateFramePattern(pattern).ok().
std::string FormatFramePattern(absl::string_view pattern, int index);

// `text` as an error message may echo it: at most `max_chars` characters of
// it, then "... (N characters)" when it is longer (a 1 MB field must not
// make a 1 MB error line).
std::string ElideForMessage(absl::string_view text, size_t max_chars = 120);
// For paths: no real path is longer (PATH_MAX), and the whole of a real one
// stays (a message's private directory prefix is replaced later).
constexpr size_t kMaxShownPathChars = 4096;

// `relative` resolved against `base_dir` (absolute paths are kept as given).
std::filesystem::path ResolvePath(const std::filesystem::path& base_dir, absl::string_view relative);

}  // namespace mvbrdf

#endif  // MVBRDF_CORE_BASE_FILES_H_
