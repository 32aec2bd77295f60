// libFuzzer target: the scene JSON loader (core/scene/sequence.h).
//
// The input is a scene.json. It is parsed (JsonToMessage, what ReadScene
// does) and validated (ValidateSceneMessage); a scene that passes is written
// to a scratch directory holding small valid files it may name — "mesh.obj"
// and "mesh_%04d.obj" (a pyramid, frames 0..3, moving), "segments.txt" — and
// loaded with LoadSequence, so that the checks past parsing (mesh, frames,
// segmentation, cameras, lights) run too. Videos are not probed (OpenCV's
// decoders are not ours to fuzz, and a probe costs milliseconds).
//
// Every input must give a Sequence or a Status with a message, never a crash,
// a hang or an allocation the input does not justify.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

#include "absl/strings/str_format.h"
#include "absl/strings/string_view.h"
#include "core/base/proto_json.h"
#include "core/scene/sequence.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

using mvbrdf::fuzz::Require;
using mvbrdf::fuzz::WriteBytes;

void WriteText(const std::filesystem::path& file, const std::string& text) {
  WriteBytes(file, reinterpret_cast<const uint8_t*>(text.data()), text.size());
}

std::string PyramidObj(int frame) {
  std::string obj;
  const double v[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}, {0.5, 1, 0.5}};
  for (const auto& p : v) obj += absl::StrFormat("v %.9g %.9g %.9g\n", p[0] + 0.1 * frame, p[1], p[2]);
  return obj + "f 1 2 3\nf 1 3 4\nf 1 5 2\nf 2 5 3\nf 3 5 4\nf 4 5 1\n";
}

// The scratch directory with the files a scene may name.
const std::filesystem::path& SceneDir() {
  static const std::filesystem::path* dir = [] {
    const std::filesystem::path& d = mvbrdf::fuzz::ScratchDir();
    WriteText(d / "mesh.obj", PyramidObj(0));
    for (int t = 0; t < 4; ++t) WriteText(d / absl::StrFormat("mesh_%04d.obj", t), PyramidObj(t));
    WriteText(d / "segments.txt", "base\nbase\nbody\nbody\nbody\nbody\n");
    return new std::filesystem::path(d);
  }();
  return *dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::filesystem::path& dir = SceneDir();
  const absl::string_view json(reinterpret_cast<const char*>(data), size);
  mvbrdf::v1::Scene scene;
  const absl::Status parsed = mvbrdf::JsonToMessage(json, "scene.json", &scene);
  mvbrdf::fuzz::Trace("parse", parsed);
  if (!parsed.ok()) {
    Require(!parsed.message().empty(), "scene_json_fuzz: a parse error without a message");
    return 0;
  }
  const absl::Status valid = mvbrdf::scene::ValidateSceneMessage(scene);
  mvbrdf::fuzz::Trace("validate", valid);
  if (!valid.ok()) {
    Require(!valid.message().empty(), "scene_json_fuzz: a validation error without a message");
    return 0;
  }
  const std::filesystem::path file = dir / "scene.json";
  WriteBytes(file, data, size);
  mvbrdf::scene::LoadOptions options;
  options.probe_videos = false;
  absl::StatusOr<mvbrdf::scene::Sequence> seq = mvbrdf::scene::LoadSequence(file, options);
  mvbrdf::fuzz::Trace("LoadSequence", seq.status());
  if (!seq.ok()) {
    Require(!seq.status().message().empty(), "scene_json_fuzz: a load error without a message");
    return 0;
  }
  Require(seq->cameras.size() == static_cast<size_t>(scene.cameras_size()), "scene_json_fuzz: camera count");
  Require(seq->lights.size() == static_cast<size_t>(scene.lights_size()), "scene_json_fuzz: light count");
  Require(seq->num_frames > 0, "scene_json_fuzz: a sequence without frames");
  (void)mvbrdf::scene::Summarize(*seq);
  for (size_t i = 0; i < seq->lights.size(); ++i) {
    Require(seq->FindLight(seq->lights[i].name) >= 0, "scene_json_fuzz: a light not found by its name");
  }
  return 0;
}
