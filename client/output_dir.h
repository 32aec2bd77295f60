// Where a command writes: an output directory (run, resample) or file
// (render) must not hold what the command reads — the scene file, its mesh,
// videos and segmentation — and only one command writes a directory at a time.
#ifndef MVBRDF_CLIENT_OUTPUT_DIR_H_
#define MVBRDF_CLIENT_OUTPUT_DIR_H_

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/scene/sequence.h"

namespace mvbrdf::client {

// A file a command reads; `pattern` when `path` is a frame pattern
// ("cam0/%04d.png": every file of its directory with its extension counts).
struct InputPath {
  std::string field;  // e.g. "scene.cameras[0].video.path", "the scene file"
  std::filesystem::path path;
  bool pattern = false;
};

// The scene file and every file the scene names (mesh, videos, segmentation).
std::vector<InputPath> SceneInputs(const scene::Sequence& sequence);
std::vector<InputPath> SceneInputs(const std::filesystem::path& scene_file, const v1::Scene& scene);

// What a command reading the output directory of `mvbrdf run` (report,
// evaluate) reads: its result.json, every file of atlas/, atlases/ and
// atlases/correction/, and, when result.json names a scene that can be read,
// that scene's inputs. What cannot be read is left out (the command reading
// it fails on its own).
// `scene_flag`: a --scene given instead of result.json's scene.
std::vector<InputPath> RunInputs(const std::filesystem::path& run_dir, const std::filesystem::path& scene_flag = {});

// INVALID_ARGUMENT when the directory `out_dir` (flag `flag`), or anything
// below it, holds one of `inputs`; paths are compared canonically (symlinks
// and ".." resolved; `out_dir` need not exist yet).
absl::Status CheckOutputDirSparesInputs(absl::string_view flag, const std::filesystem::path& out_dir,
                                        const std::vector<InputPath>& inputs);

// INVALID_ARGUMENT when writing the file `out_file` would overwrite one of
// `inputs` (for a pattern: a file of its directory with its extension).
absl::Status CheckOutputFileSparesInputs(absl::string_view flag, const std::filesystem::path& out_file,
                                         const std::vector<InputPath>& inputs);

// An exclusive lock on an output directory (flock on DIR/.mvbrdf.lock, taken
// without waiting), held while the object lives; the directory is created.
// A second command writing the same directory fails at once (UNAVAILABLE,
// naming the directory) instead of mixing its files with the first's.
class OutputDirLock {
 public:
  static absl::StatusOr<OutputDirLock> Acquire(absl::string_view flag, const std::filesystem::path& dir);
  OutputDirLock(OutputDirLock&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }
  OutputDirLock& operator=(OutputDirLock&&) = delete;
  OutputDirLock(const OutputDirLock&) = delete;
  ~OutputDirLock();

 private:
  explicit OutputDirLock(int fd) : fd_(fd) {}
  int fd_ = -1;
};

// The file each command writing an output directory (run, resample, synth,
// fetch) leaves in it: the mark of a directory mvbrdf wrote, the only kind
// `--force` clears.
inline constexpr char kOutputMarker[] = ".mvbrdf-output";

// What --help says about --force.
inline constexpr char kForceHelp[] =
    "clear a non-empty output directory first; only one an mvbrdf command wrote (holding .mvbrdf-output) is "
    "cleared, any other is refused and nothing is deleted";

// Takes the output directory `dir` (flag `flag`) for a command: a directory
// holding anything but the lock and the marker is refused (INVALID_ARGUMENT,
// naming a file it holds) unless `force`; with `force` it is emptied first,
// but only when it holds kOutputMarker, so a mistyped --out ($HOME) is never
// deleted (refused as without --force, nothing removed). Then locks it as
// OutputDirLock::Acquire and writes the marker.
absl::StatusOr<OutputDirLock> PrepareOutputDir(absl::string_view flag, const std::filesystem::path& dir, bool force);

}  // namespace mvbrdf::client

#endif  // MVBRDF_CLIENT_OUTPUT_DIR_H_
