// Sequence bundles (issue #5): a scene file and every file it references in
// one uncompressed tar, the unit a scene travels in from the CLI client to the
// server and workers, content-addressed by the SHA-256 of the archive bytes.
//
// Packing is deterministic: entries sorted by path, mtime 0, uid/gid 0, mode
// 0644, no directories, no owner names, so packing the same scene twice gives
// byte-identical archives (and the same hash, hence one stored copy).
//
// Unpacking is strict (issue #7: no file outside a bundle is ever written
// because of a request): only regular files, every path relative and
// normalised, size and count limits, extraction into a temporary directory
// renamed into place only when everything succeeded.
#ifndef MVBRDF_CORE_BUNDLE_BUNDLE_H_
#define MVBRDF_CORE_BUNDLE_BUNDLE_H_

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/bundle/sha256.h"

namespace mvbrdf::bundle {

struct PackOptions {
  // Also pack ground_truth/truth.json and the files it names when the
  // directory ground_truth/ exists beside the scene (synthetic scenes).
  bool include_ground_truth = true;
};

struct UnpackOptions {
  // Most entries a bundle may hold.
  int64_t max_files = 1'000'000;
  // Most bytes of one entry and of all entries together (file contents).
  int64_t max_file_bytes = int64_t{16} << 30;   // 16 GiB
  int64_t max_total_bytes = int64_t{64} << 30;  // 64 GiB
  // When not empty: the archive's SHA-256 (hex, either case) must equal it,
  // checked before anything is extracted.
  std::string expected_sha256;

  absl::Status Check() const;
};

struct BundleInfo {
  std::string sha256;  // lowercase hex of the archive bytes
  int64_t size = 0;    // archive size in bytes
  int num_files = 0;   // entries, the scene file included
  std::string scene_name;  // the scene file's path inside, e.g. "scene.json"
};

// The scene file and every file it references, relative to the scene's
// directory ('/'-separated, normalised, sorted, unique): the mesh (every frame
// of a pattern, and the buffers and images a text .gltf names by URI), each camera's video (every frame of an image
// pattern), the segmentation, and (options.include_ground_truth) ground_truth/truth.json with the textures it names.
// Errors: the scene's own parse/validation errors; NOT_FOUND naming the field for a missing file; INVALID_ARGUMENT for
// a path that leaves the scene's directory (absolute, "..", or a symlink resolving outside) - a bundle is
// self-contained.
absl::StatusOr<std::vector<std::string>> BundleFiles(const std::filesystem::path& scene_file,
                                                     const PackOptions& options = {});

// Writes the bundle of `scene_file` to `archive` (a temporary file beside it,
// renamed into place, so a reader never sees a half-written archive).
absl::StatusOr<BundleInfo> PackBundle(const std::filesystem::path& scene_file, const std::filesystem::path& archive,
                                      const PackOptions& options = {});

// Extracts `archive` into `dest_dir` (which must not exist, or be an empty
// directory) and returns the scene file inside it: "scene.json" at the top
// level, else the only top-level ".json" file. On any error nothing is left
// behind. Errors: INVALID_ARGUMENT naming the offending entry (non-regular
// file, bad path, duplicate) or a hash mismatch; RESOURCE_EXHAUSTED naming the
// limit and the entry; DATA_LOSS for a truncated or corrupt archive;
// ALREADY_EXISTS when dest_dir is a non-empty directory or a file.
absl::StatusOr<std::filesystem::path> UnpackBundle(const std::filesystem::path& archive,
                                                   const std::filesystem::path& dest_dir,
                                                   const UnpackOptions& options = {});

// The scene file inside an unpacked bundle directory. `scene_path` empty:
// "scene.json" at the top, else the only top-level ".json" file; otherwise a
// relative, normalised path without ".." naming a regular file. Errors are
// INVALID_ARGUMENT naming `scene_path`.
absl::StatusOr<std::filesystem::path> SceneFileIn(const std::filesystem::path& dir, absl::string_view scene_path);
// INVALID_ARGUMENT naming `scene_path` unless it is empty or a relative,
// normalised path without "..".
absl::Status CheckScenePath(absl::string_view scene_path);

}  // namespace mvbrdf::bundle

#endif  // MVBRDF_CORE_BUNDLE_BUNDLE_H_
