// File-system helpers: whole-file I/O and frame-numbered path patterns.
#ifndef MVBRDF_CORE_BASE_FILES_H_
#define MVBRDF_CORE_BASE_FILES_H_

#include <filesystem>
#include <string>
#include "absl/strings/string_view.h"

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace mvbrdf {

// Reads a whole file. NOT_FOUND names the path when it does not exist.
absl::StatusOr<std::string> ReadFileToString(const std::filesystem::path& path);

// Writes a whole file, creating parent directories. Writes to a temporary
// file beside it and renames, so a reader never sees a half-written file.
absl::Status WriteStringToFile(const std::filesystem::path& path, absl::string_view contents);

// The status of a failed system call on `path`, from its errno `error`:
// "path: what: strerror(error)", RESOURCE_EXHAUSTED for a full disk, quota or
// file size limit, NOT_FOUND, PERMISSION_DENIED (also a read-only file
// system), UNAVAILABLE for I/O errors and no free descriptors, else INTERNAL.
absl::Status ErrnoStatus(int error, absl::string_view what, absl::string_view path);

// Writes all of `bytes` to the descriptor `fd` (short writes and EINTR
// retried). Errors as ErrnoStatus, naming `path`.
absl::Status WriteAllToFd(int fd, absl::string_view bytes, absl::string_view path);

// True when `pattern` holds exactly one printf integer conversion
// ("%d", "%04d", "%5u"...), e.g. "mesh_%04d.obj".
bool IsFramePattern(absl::string_view pattern);

// Checks that `pattern` is usable as a frame pattern: at most one integer
// conversion, no other conversions ("%%" is a literal percent sign).
// `field` names the pattern in the error, e.g. "scene.mesh.path".
absl::Status ValidateFramePattern(absl::string_view pattern, absl::string_view field);

// Expands a frame pattern with `index`; returns `pattern` unchanged when it
// holds no conversion. Requires ValidateFramePattern(pattern).ok().
std::string FormatFramePattern(absl::string_view pattern, int index);

// `relative` resolved against `base_dir` (absolute paths are kept as given).
std::filesystem::path ResolvePath(const std::filesystem::path& base_dir, absl::string_view relative);

}  // namespace mvbrdf

#endif  // MVBRDF_CORE_BASE_FILES_H_
