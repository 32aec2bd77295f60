// How result.json names the scene it was made from (issue #20 item 3): a run
// directory must survive being moved with its input, and a result fetched
// from the service must not point into a worker's cache.
#ifndef MVBRDF_CORE_PIPELINE_RUN_SCENE_H_
#define MVBRDF_CORE_PIPELINE_RUN_SCENE_H_

#include <filesystem>
#include <string>

#include "absl/status/statusor.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::pipeline {

// RunReport.scene of a direct run writing to `out_dir`: `scene_file` relative
// to out_dir (both with symlinks resolved), so that moving the input and the
// output together keeps it valid; absolute only when no relative path exists.
std::string SceneRelativeTo(const std::filesystem::path& scene_file, const std::filesystem::path& out_dir);

// The scene file of the run in `run_dir`: `scene_flag` when given (a --scene
// flag), else RunReport.scene resolved against run_dir (absolute paths kept).
// NOT_FOUND when that file does not exist, naming result.json's scene and, for
// a service result (bundle_sha256 set; scene is a path inside that bundle),
// the bundle and --scene.
absl::StatusOr<std::filesystem::path> SceneOfRun(const std::filesystem::path& run_dir, const v1::RunReport& run,
                                                 const std::filesystem::path& scene_flag = {});

// The scene of the run (SceneOfRun) loaded for reading the run back (render,
// report, export): frames checked when read, videos not probed.
absl::StatusOr<scene::Sequence> LoadSceneOfRun(const std::filesystem::path& run_dir, const v1::RunReport& run,
                                               const std::filesystem::path& scene_flag = {});

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_RUN_SCENE_H_
