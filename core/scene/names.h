// Names a scene gives to its cameras, lights, light configurations, material
// seeds and segments. They reach file names (frames/0000/<camera>.exr), HTML
// reports and terminals, so a name is a single, printable path component:
// checked once when the scene is validated (ValidateName), and every file
// name made from one goes through FileNameFor, which refuses (rather than
// writes outside its directory) a name that escaped validation.
#ifndef MVBRDF_CORE_SCENE_NAMES_H_
#define MVBRDF_CORE_SCENE_NAMES_H_

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace mvbrdf::scene {

// The longest name, in bytes (UTF-8).
inline constexpr size_t kMaxNameBytes = 128;

// OK for a name usable as one file-name component: non-empty, at most
// kMaxNameBytes bytes of valid UTF-8, not "." or "..", no '/', '\\', NUL or
// other control character (C0, DEL, C1). Non-ASCII letters ("café") are
// fine. INVALID_ARGUMENT "<field>: ..." otherwise, with the name shown
// escaped (control bytes as \x1b).
absl::Status ValidateName(absl::string_view field, absl::string_view name);

// `dir / (name + suffix)`, e.g. FileNameFor(frame_dir, "cam0", "_grown.exr").
// INVALID_ARGUMENT when `name` fails ValidateName or the result would not be
// a file directly inside `dir` (so a name can never place a file elsewhere).
absl::StatusOr<std::filesystem::path> FileNameFor(const std::filesystem::path& dir, absl::string_view name,
                                                  absl::string_view suffix);

// `name` as shown in a message or a terminal: printable UTF-8 (café) as it
// is, control characters (C0, DEL, C1) and invalid UTF-8 as \xNN per byte, so
// a name that failed or escaped validation cannot send ESC or cut a line.
std::string ShownName(absl::string_view name);

// ShownName of each line of `text`, the newlines kept (messages, summaries).
std::string ShownText(absl::string_view text);

// The valid names of something, for an error message: "\"a\", \"b\", \"c\""
// (each ShownName, quoted), the first `max_shown` of more than that followed
// by "… (N in all)"; "none" when there are none.
std::string NameList(const std::vector<std::string>& names, size_t max_shown = 10);

// The name of `candidates` closest to `name` by edit distance (case
// ignored), when it is close enough to be a likely typo (at most 2 edits or
// a third of its length, fewer than its length, not equal); empty otherwise.
std::string ClosestName(absl::string_view name, const std::vector<std::string>& candidates);

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_NAMES_H_
