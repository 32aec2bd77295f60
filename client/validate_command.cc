// `mvbrdf validate SCENE`: load and check everything, print a summary.
// `--fix OUT.json` first repairs rounding (rotations, light directions).
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/flags.h"
#include "core/base/proto_json.h"
#include "core/scene/names.h"
#include "core/scene/scene_fix.h"
#include "core/scene/sequence.h"

namespace mvbrdf::client {

int RunValidate(const std::vector<std::string>& args) {
  std::string scene_file;
  bool quick = false;
  FlagParser flags("validate",
                   "Loads a scene, validates every field, mesh frame and video frame, and prints a summary\n"
                   "(frames, cameras, lights, triangles, what was excluded) or the first error.");
  flags.AddPositional("SCENE", &scene_file, true, "the scene JSON file");
  flags.AddBool("--quick", &quick, "check only frame 0's mesh and skip the videos");
  std::string fix_out;
  flags.AddString("--fix FILE", &fix_out,
                  "OUT.json: write the scene with each camera rotation replaced by the nearest rotation (SVD)\n"
                  "      and light directions scaled to unit length, print what changed, then validate OUT.json.\n"
                  "      Refused (exit 3): det < 0 or max |R*R^T - I| > 1e-3 (not rounding), a zero direction.\n"
                  "      OUT.json goes in SCENE's directory (the scene's paths are relative to it)");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf validate: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  if (!fix_out.empty()) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path scene_dir = fs::weakly_canonical(fs::absolute(scene_file).parent_path(), ec);
    const fs::path out_dir = fs::weakly_canonical(fs::absolute(fix_out).parent_path(), ec);
    if (scene_dir != out_dir) {
      std::fprintf(stderr,
                   "mvbrdf validate: --fix: %s must be in the scene's directory %s (its paths are relative to it)\n",
                   fix_out.c_str(), scene_dir.string().c_str());
      return kExitUsage;
    }
    absl::StatusOr<v1::Scene> scene = scene::ReadScene(scene_file);
    if (!scene.ok()) return ReportFailure(scene.status());
    std::vector<std::string> changes;
    if (absl::Status s = scene::FixRounding(&*scene, &changes); !s.ok()) return ReportFailure(s);
    if (absl::Status s = WriteJsonFile(fix_out, *scene); !s.ok()) return ReportFailure(s);
    for (const std::string& line : changes) std::printf("fixed: %s\n", scene::ShownText(line).c_str());
    std::printf("wrote %s (%zu change%s)\n", fix_out.c_str(), changes.size(), changes.size() == 1 ? "" : "s");
    scene_file = fix_out;
  }
  scene::LoadOptions options;
  options.check_all_frames = !quick;
  options.probe_videos = !quick;
  options.read_every_video_frame = !quick;
  auto sequence = scene::LoadSequence(scene_file, options);
  if (!sequence.ok()) return ReportFailure(sequence.status());
  // Written whole (a NUL in the free-form scene.name must not cut it short),
  // with control characters other than newlines shown as \xNN.
  const std::string summary = scene::ShownText(scene::Summarize(*sequence));
  std::fwrite(summary.data(), 1, summary.size(), stdout);
  // What "valid" covers, so that it promises no more than was looked at.
  if (quick) {
    std::printf(
        "checked: the scene's fields, frame 0's mesh, that each camera sees it, lights; not checked "
        "(--quick): later mesh frames, the videos\n");
  } else {
    std::printf(
        "checked: the scene's fields, every mesh frame, every used video frame decoded (size, bit depth, "
        "count), that each camera sees the mesh in frame 0, lights; not checked: what a camera sees after "
        "occlusion (a run reports cameras that observe nothing)\n");
  }
  std::printf("valid: %s\n", scene_file.c_str());
  return kExitOk;
}

}  // namespace mvbrdf::client
