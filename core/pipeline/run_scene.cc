#include "core/pipeline/run_scene.h"

#include <system_error>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/base/files.h"

namespace mvbrdf::pipeline {

namespace fs = std::filesystem;

std::string SceneRelativeTo(const fs::path& scene_file, const fs::path& out_dir) {
  std::error_code ec;
  fs::path scene = fs::weakly_canonical(fs::absolute(scene_file, ec), ec);
  if (ec) scene = fs::absolute(scene_file, ec).lexically_normal();
  fs::path out = fs::weakly_canonical(fs::absolute(out_dir, ec), ec);
  if (ec) out = fs::absolute(out_dir, ec).lexically_normal();
  const fs::path relative = scene.lexically_relative(out);
  return relative.empty() ? scene.string() : relative.generic_string();
}

absl::StatusOr<fs::path> SceneOfRun(const fs::path& run_dir, const v1::RunReport& run, const fs::path& scene_flag) {
  if (!scene_flag.empty()) {
    std::error_code ec;
    if (!fs::is_regular_file(scene_flag, ec)) {
      return absl::NotFoundError(absl::StrCat("--scene ", scene_flag.string(), ": no such file"));
    }
    return scene_flag;
  }
  const fs::path result = run_dir / "result.json";
  if (run.scene().empty()) {
    return absl::NotFoundError(absl::StrCat(result.string(), ": names no scene (scene is empty); give --scene FILE"));
  }
  const fs::path scene = ResolvePath(run_dir, run.scene());
  std::error_code ec;
  if (fs::is_regular_file(scene, ec)) return scene;
  if (!run.bundle_sha256().empty()) {
    return absl::NotFoundError(absl::StrCat(result.string(), ": a service result; its scene \"", run.scene(),
                                            "\" is a path inside the uploaded bundle ", run.bundle_sha256(),
                                            " (bundle_sha256), not found as ", scene.string(),
                                            ": give the scene file of that bundle with --scene FILE"));
  }
  return absl::NotFoundError(absl::StrCat(result.string(), ": its scene \"", run.scene(),
                                          "\" (relative to the directory of result.json) is not found as ",
                                          scene.string(), "; move the input with the output, or give --scene FILE"));
}

absl::StatusOr<scene::Sequence> LoadSceneOfRun(const std::filesystem::path& run_dir, const v1::RunReport& run,
                                               const std::filesystem::path& scene_flag) {
  MVBRDF_ASSIGN_OR_RETURN(const std::filesystem::path scene_file, SceneOfRun(run_dir, run, scene_flag));
  scene::LoadOptions load;
  load.check_all_frames = false;
  load.probe_videos = false;
  return scene::LoadSequence(scene_file, load);
}

}  // namespace mvbrdf::pipeline
