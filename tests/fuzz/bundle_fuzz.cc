// libFuzzer target: UnpackBundle (core/bundle/bundle.h), the strict tar
// extraction of sequence bundles a request hands the server and workers.
//
// The input is the archive. Each run unpacks it into `root/dest` of a fresh
// `root` and then asserts what issue #7 promises: nothing is ever written
// outside the destination (the root holds only the archive and, on success,
// `dest`), on failure nothing is left behind, and what is extracted is only
// regular files and directories (no symlinks, devices or FIFOs), with the
// returned scene file a regular file directly inside `dest`.
#include <sys/stat.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>

#include "core/bundle/bundle.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

namespace fs = std::filesystem;
using mvbrdf::fuzz::Require;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const fs::path root = mvbrdf::fuzz::ScratchDir() / "root";
  std::error_code ec;
  fs::remove_all(root, ec);
  Require(fs::create_directory(root, ec), "bundle_fuzz: cannot create the root");
  const fs::path archive = root / "bundle.tar";
  const fs::path dest = root / "dest";
  mvbrdf::fuzz::WriteBytes(archive, data, size);

  mvbrdf::bundle::UnpackOptions options;
  // Small limits so the size checks are reached by small inputs.
  options.max_files = 64;
  options.max_file_bytes = 1 << 20;
  options.max_total_bytes = 2 << 20;
  absl::StatusOr<fs::path> scene = mvbrdf::bundle::UnpackBundle(archive, dest, options);

  mvbrdf::fuzz::Trace("UnpackBundle", scene.status());
  // Nothing beside the archive and dest in the root.
  for (const fs::directory_entry& e : fs::directory_iterator(root)) {
    const bool expected = e.path() == archive || (scene.ok() && e.path() == dest);
    if (!expected) {
      std::fprintf(stderr, "bundle_fuzz: unexpected %s (unpack %s)\n", e.path().c_str(),
                   scene.ok() ? "succeeded" : std::string(scene.status().ToString()).c_str());
    }
    Require(expected, "bundle_fuzz: something was written outside the destination or left behind");
  }
  Require(fs::is_regular_file(fs::symlink_status(archive)) && fs::file_size(archive) == size,
          "bundle_fuzz: the archive was modified");
  if (!scene.ok()) {
    Require(!scene.status().message().empty(), "bundle_fuzz: an error without a message");
    Require(!fs::exists(fs::symlink_status(dest)), "bundle_fuzz: a failed unpack left the destination behind");
    return 0;
  }
  Require(scene->parent_path() == dest, "bundle_fuzz: the scene file is not at the top of the destination");
  Require(fs::is_regular_file(fs::symlink_status(*scene)), "bundle_fuzz: the scene file is not a regular file");
  Require(fs::is_directory(fs::symlink_status(dest)), "bundle_fuzz: the destination is not a directory");
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(dest)) {
    const fs::file_status s = fs::symlink_status(e.path());
    Require(fs::is_regular_file(s) || fs::is_directory(s), "bundle_fuzz: extracted something not a file or folder");
    Require((static_cast<unsigned>(s.permissions()) & (S_ISUID | S_ISGID)) == 0,
            "bundle_fuzz: extracted a set-uid or set-gid file");
  }
  return 0;
}
