// `mvbrdf validate SCENE`: load and check everything, print a summary.
#include <cstdio>
#include <string>

#include "absl/strings/str_cat.h"
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
  // Written whole (a NUL in the free-form scene.name must not cut it short),
  // with control characters other than newlines shown as \xNN.
  std::string summary;
  for (const char c : scene::Summarize(*sequence)) {
    const auto byte = static_cast<unsigned char>(c);
    if ((byte < 0x20 && c != '\n') || byte == 0x7f) {
      absl::StrAppend(&summary, "\\x", absl::Hex(byte, absl::kZeroPad2));
    } else {
      summary += c;
    }
  }
  std::fwrite(summary.data(), 1, summary.size(), stdout);
  std::printf("valid: %s\n", scene_file.c_str());
  return kExitOk;
}

}  // namespace mvbrdf::client
