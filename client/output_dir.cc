#include "client/output_dir.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <optional>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/pipeline/run_scene.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::client {
namespace {

namespace fs = std::filesystem;

// `path` absolute, with symlinks of its existing part and ".." resolved.
fs::path Canonical(const fs::path& path) {
  std::error_code ec;
  fs::path absolute = fs::absolute(path, ec);
  if (ec) absolute = path;
  fs::path canonical = fs::weakly_canonical(absolute, ec);
  return (ec ? absolute : canonical).lexically_normal();
}

// True when `dir` is `path` or one of its ancestors (both canonical).
bool Holds(const fs::path& dir, const fs::path& path) {
  auto d = dir.begin(), p = path.begin();
  for (; d != dir.end(); ++d, ++p) {
    if (d->empty()) continue;  // a trailing separator
    if (p == path.end() || *d != *p) return false;
  }
  return true;
}

std::string Shown(const InputPath& input) { return absl::StrCat(input.field, " (", input.path.string(), ")"); }

}  // namespace

std::vector<InputPath> SceneInputs(const scene::Sequence& sequence) {
  return SceneInputs(sequence.scene_file, sequence.scene);
}

std::vector<InputPath> SceneInputs(const fs::path& scene_file, const v1::Scene& s) {
  std::vector<InputPath> inputs;
  inputs.push_back({"the scene file", scene_file, false});
  const fs::path scene_dir = scene_file.has_parent_path() ? scene_file.parent_path() : fs::path(".");
  const auto add = [&](const std::string& field, const std::string& relative) {
    if (relative.empty()) return;
    inputs.push_back({field, ResolvePath(scene_dir, relative), IsFramePattern(relative)});
  };
  add("scene.mesh.path", s.mesh().path());
  for (int i = 0; i < s.cameras_size(); ++i) {
    add(absl::StrCat("scene.cameras[", i, "].video.path"), s.cameras(i).video().path());
  }
  add("scene.segmentation_path", s.segmentation_path());
  return inputs;
}

std::vector<InputPath> RunInputs(const fs::path& run_dir, const fs::path& scene_flag) {
  std::vector<InputPath> inputs;
  inputs.push_back({"the run's result.json", run_dir / "result.json", false});
  // A pattern stands for every file of its directory with its extension.
  for (const char* dir : {"atlas", "atlases", "atlases/correction"}) {
    for (const char* ext : {"exr", "png", "obj"}) {
      inputs.push_back({absl::StrCat("the run's ", dir, "/*.", ext), run_dir / dir / absl::StrCat("%04d.", ext), true});
    }
  }
  absl::StatusOr<v1::RunReport> run = ReadJsonFileAs<v1::RunReport>(run_dir / "result.json");
  if (run.ok()) {
    const absl::StatusOr<fs::path> scene_file = pipeline::SceneOfRun(run_dir, *run, scene_flag);
    absl::StatusOr<v1::Scene> scene =
        scene_file.ok() ? scene::ReadScene(*scene_file) : absl::StatusOr<v1::Scene>(scene_file.status());
    if (scene.ok()) {
      for (InputPath& input : SceneInputs(*scene_file, *scene)) inputs.push_back(std::move(input));
    } else if (scene_file.ok()) {
      inputs.push_back({"the run's scene file", *scene_file, false});
    }
  }
  return inputs;
}

absl::Status CheckOutputDirSparesInputs(absl::string_view flag, const fs::path& out_dir,
                                        const std::vector<InputPath>& inputs) {
  const fs::path out = Canonical(out_dir);
  for (const InputPath& input : inputs) {
    if (Holds(out, Canonical(input.path.parent_path()))) {
      return absl::InvalidArgumentError(absl::StrCat(flag, " ", out_dir.string(), ": holds ", Shown(input),
                                                     ", which the command reads; writing there could overwrite it "
                                                     "(choose a directory that holds no input)"));
    }
  }
  return absl::OkStatus();
}

absl::Status CheckOutputFileSparesInputs(absl::string_view flag, const fs::path& out_file,
                                         const std::vector<InputPath>& inputs) {
  const fs::path out = Canonical(out_file);
  for (const InputPath& input : inputs) {
    const fs::path in = Canonical(input.path);
    const bool same =
        input.pattern ? out.parent_path() == in.parent_path() && out.extension() == in.extension() : out == in;
    if (same) {
      return absl::InvalidArgumentError(
          absl::StrCat(flag, " ", out_file.string(), ": would overwrite ", Shown(input), ", which the command reads"));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<OutputDirLock> OutputDirLock::Acquire(absl::string_view flag, const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return ErrnoStatus(ec.value(), absl::StrCat(flag, ": cannot create the directory"), dir.string());
  const fs::path lock_file = dir / ".mvbrdf.lock";
  const int fd = ::open(lock_file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return ErrnoStatus(errno, absl::StrCat(flag, ": cannot open the lock file"), lock_file.string());
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    ::close(fd);
    if (error == EWOULDBLOCK) {
      return absl::UnavailableError(absl::StrCat(flag, " ", dir.string(),
                                                 ": another mvbrdf command is writing this directory (it holds ",
                                                 lock_file.string(), "); wait for it or choose another directory"));
    }
    return ErrnoStatus(error, absl::StrCat(flag, ": cannot lock"), lock_file.string());
  }
  return OutputDirLock(fd);
}

OutputDirLock::~OutputDirLock() {
  if (fd_ >= 0) ::close(fd_);
}

absl::StatusOr<OutputDirLock> PrepareOutputDir(absl::string_view flag, const fs::path& dir, bool force) {
  // What the directory holds besides the lock and the marker (the first
  // entry, by name, for the message), and whether it holds the marker.
  std::error_code ec;
  const auto inspect = [&](std::string* first, bool* marked) -> absl::Status {
    first->clear();
    *marked = false;
    if (!fs::exists(dir, ec)) return absl::OkStatus();
    if (!fs::is_directory(dir, ec)) {
      return absl::InvalidArgumentError(absl::StrCat(flag, " ", dir.string(), ": is not a directory"));
    }
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
      const std::string name = it->path().filename().string();
      if (name == kOutputMarker) {
        *marked = true;
      } else if (name != ".mvbrdf.lock" && (first->empty() || name < *first)) {
        *first = name;
      }
    }
    if (ec) return ErrnoStatus(ec.value(), absl::StrCat(flag, ": cannot list the directory"), dir.string());
    return absl::OkStatus();
  };
  // A directory mvbrdf locked before is locked first, so that a command
  // still writing it is reported as such (UNAVAILABLE); any other directory
  // is inspected before anything is created in it.
  std::optional<OutputDirLock> lock;
  if (fs::exists(fs::path(dir) / ".mvbrdf.lock", ec)) {
    MVBRDF_ASSIGN_OR_RETURN(OutputDirLock taken, OutputDirLock::Acquire(flag, dir));
    lock.emplace(std::move(taken));
  }
  std::string first;
  bool marked = false;
  MVBRDF_RETURN_IF_ERROR(inspect(&first, &marked));
  if (!first.empty() && !force) {
    return absl::InvalidArgumentError(
        absl::StrCat(flag, " ", dir.string(), ": not empty (it holds ", first,
                     "); give --force to clear it first (only a directory mvbrdf wrote, holding ", kOutputMarker,
                     ", is cleared) or choose another directory"));
  }
  if (!first.empty() && !marked) {
    return absl::InvalidArgumentError(
        absl::StrCat(flag, " ", dir.string(), ": --force clears only a directory mvbrdf wrote, and this one holds no ",
                     kOutputMarker, " (it holds ", (fs::path(dir) / first).string(),
                     "); nothing was deleted: empty it yourself or choose another directory"));
  }
  if (!lock.has_value()) {
    MVBRDF_ASSIGN_OR_RETURN(OutputDirLock taken, OutputDirLock::Acquire(flag, dir));
    lock.emplace(std::move(taken));
  }
  if (force && !first.empty()) {
    // Under the lock, listed before anything is removed.
    std::vector<fs::path> entries;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
      if (it->path().filename() != ".mvbrdf.lock") entries.push_back(it->path());
    }
    if (ec) return ErrnoStatus(ec.value(), absl::StrCat(flag, ": cannot list the directory"), dir.string());
    for (const fs::path& entry : entries) {
      std::error_code remove_error;
      fs::remove_all(entry, remove_error);  // a symlink is removed, not followed
      if (remove_error) {
        return ErrnoStatus(remove_error.value(), absl::StrCat(flag, " --force: cannot remove"), entry.string());
      }
    }
  }
  // An empty file: it takes no data block, so a full disk still lets the
  // command report its own write failure.
  const fs::path marker = fs::path(dir) / kOutputMarker;
  const int fd = ::open(marker.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return ErrnoStatus(errno, absl::StrCat(flag, ": cannot create the marker file"), marker.string());
  ::close(fd);
  return std::move(*lock);
}

}  // namespace mvbrdf::client
