// `mvbrdf validate SCENE`: load and check everything, print a summary.
#include <cstdio>
#include <string>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/flags.h"
#include "core/scene/names.h"
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
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf validate: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
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
