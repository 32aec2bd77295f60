// `mvbrdf validate SCENE`: load and check everything, print a summary.
#include <cstdio>

#include "client/commands.h"
#include "client/flags.h"
#include "core/scene/sequence.h"

namespace mvbrdf::client {

int RunValidate(const std::vector<std::string>& args) {
  std::string scene_file;
  bool quick = false;
  FlagParser flags("validate",
                   "Loads a scene, validates every field, mesh frame and video, and prints a summary\n"
                   "(frames, cameras, lights, triangles, what was excluded) or the first error.");
  flags.AddPositional("SCENE", &scene_file, true, "the scene JSON file");
  flags.AddBool("--quick", &quick, "check only frame 0's mesh and skip probing the videos");
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
  auto sequence = scene::LoadSequence(scene_file, options);
  if (!sequence.ok()) return ReportFailure(sequence.status());
  std::fputs(scene::Summarize(*sequence).c_str(), stdout);
  std::printf("valid: %s\n", scene_file.c_str());
  return kExitOk;
}

}  // namespace mvbrdf::client
