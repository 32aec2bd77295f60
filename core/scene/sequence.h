// A scene file loaded and validated: the Scene message plus what every later
// stage needs (mesh topology, camera models, lights), with every error a user
// can cause reported as a Status naming the field or file and what was
// expected, e.g. "scene.cameras[3].intrinsics.fx: must be > 0, got -1".
#ifndef MVBRDF_CORE_SCENE_SEQUENCE_H_
#define MVBRDF_CORE_SCENE_SEQUENCE_H_

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/scene/light.h"
#include "core/scene/camera_model.h"
#include "core/scene/frame_cache.h"
#include "core/scene/mesh.h"
#include "core/scene/video_source.h"
#include "mvbrdf/v1/scene.pb.h"

namespace mvbrdf::scene {

struct LoadOptions {
  // Load every frame's mesh file to check topology and finiteness (a static
  // mesh has nothing to check). Off: only frame 0 is read now.
  bool check_all_frames = true;
  // Open every video to check its frame size and frame count.
  bool probe_videos = true;
  // Decode every used frame of every video (size, bit depth, the video not
  // ending early), as a run will: what `mvbrdf validate` does unless --quick.
  // Off: only what probe_videos checks (a container's stated frame count).
  bool read_every_video_frame = false;
};

struct Sequence {
  std::filesystem::path scene_file;
  std::filesystem::path scene_dir;
  v1::Scene scene;
  MeshTopology topology;
  FramePositions rest_positions;  // frame 0
  std::vector<CameraModel> cameras;
  std::vector<Light> lights;
  int num_frames = 0;
  // Frame t of the sequence is file / video / mesh frame frames.Absolute(t)
  // (scene.frames: first + t * step, or indices[t]).
  FrameSelection frames;

  bool is_static_mesh() const;
  // File-vertex positions of frame t in [0, num_frames): frame 0's for a
  // static mesh, else the frame's file (read and topology checked the first
  // time, then from frame_cache while it fits).
  absl::StatusOr<FramePositions> LoadFrame(int t) const;
  // The frames LoadFrame read (by file path); copies of the sequence share it.
  std::shared_ptr<FrameCache> frame_cache = std::make_shared<FrameCache>();
  // The absolute frame index of frame t: what mesh patterns, image patterns,
  // masks, frame_lighting and per-frame outputs are numbered by.
  int AbsoluteFrame(int t) const { return frames.Absolute(t); }
  // Index of a light by name, or -1.
  int FindLight(const std::string& name) const;
  // The scene.frame_lighting entry of frame t in [0, num_frames) (absolute
  // frame AbsoluteFrame(t)), or null: that frame has all lights of the
  // configuration under test on. Entries for frames that frames.step or
  // frames.indices skip are ignored (validate's summary counts them).
  const v1::FrameLighting* FrameLightingOf(int t) const;
  // Whether every frame has its own entry: the lights of each frame are
  // known, and no configuration needs to be chosen (no light sweep).
  bool every_frame_lit_own() const;
};

// The name a run reports as its configuration when every frame has its own
// lights (Sequence::every_frame_lit_own); `mvbrdf synth --lighting olat`
// writes it as the truth's active configuration.
inline constexpr char kPerFrameLighting[] = "per-frame lighting";

// The frames a (validated) scene.frames selects, and how many.
FrameSelection SelectedFrames(const v1::Frames& frames);
int NumSelectedFrames(const v1::Frames& frames);

// A file the scene names (`relative`, as `field` names it) must lie inside
// the scene's folder through any symlinks: a link inside it is followed (and
// its target packed into a bundle as a regular file); one that resolves
// outside is refused, by validate, run --direct, run and submit alike, with
// this message (a bundle is self-contained, and a server never reads outside
// it). OK when the file does not exist (its reader says so).
absl::Status CheckResolvesInsideSceneDir(const std::filesystem::path& scene_dir, const std::string& relative,
                                         const std::string& field);

// Parses only (JSON -> message), no validation and no files touched.
absl::StatusOr<v1::Scene> ReadScene(const std::filesystem::path& scene_file);

// Checks the message alone (no files): required fields, ranges, names.
absl::Status ValidateSceneMessage(const v1::Scene& scene);

// Checks a camera's image size, intrinsics, distortion and pose as the
// scene's cameras are checked (finite, orthonormal rotation, sizes in
// 1..kMaxImageSide), not its name or video; `field` prefixes the fields named
// in errors (e.g. "scene.cameras[0]"). For cameras given alone (render --camera FILE).
constexpr uint32_t kMaxImageSide = 65536;
absl::Status ValidateCameraGeometry(const v1::Camera& camera, const std::string& field);

// Parses, validates the message, loads the mesh and (as `options` say) every
// frame and video.
absl::StatusOr<Sequence> LoadSequence(const std::filesystem::path& scene_file, const LoadOptions& options = {});

// Human-readable summary for `mvbrdf validate`: frames, cameras, lights,
// configurations, triangles, what was excluded and why.
std::string Summarize(const Sequence& sequence);

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_SEQUENCE_H_
