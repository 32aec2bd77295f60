// What the synthetic studio films: a mesh with fixed connectivity, its pose
// per frame, and the true material of every triangle.
#ifndef MVBRDF_CORE_SYNTH_SUBJECT_H_
#define MVBRDF_CORE_SYNTH_SUBJECT_H_

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "core/scene/mesh.h"
#include "core/synth/studio.h"

namespace mvbrdf::synth {

struct Subject {
  std::string preset;
  scene::MeshTopology topology;
  scene::FramePositions rest_positions;  // frame 0
  // File-vertex positions of frame t (t = 0 gives rest_positions).
  std::function<absl::StatusOr<scene::FramePositions>(int t)> pose;
  int max_frames = 0;  // 0 = unlimited
  std::vector<StudioMaterial> materials;
  std::vector<uint32_t> triangle_material;  // per triangle
  // Spot: the true kd in UV space as linear RGB CV_32FC3 (row 0 = v = 1),
  // used by material 0 instead of its solid texture.
  cv::Mat kd_texture;
  std::filesystem::path kd_texture_file;
  // Optional per-triangle segment names (the actor's body parts).
  std::vector<std::string> segment_names;
  std::vector<uint32_t> triangle_segment;
};

// The procedural actor (no outside data), at `fps` frames per second.
Subject MakeActorSubject(int segments, double fps);
// Spot on a turntable (one revolution per 120 frames), kd from its texture.
absl::StatusOr<Subject> MakeSpotSubject(const std::filesystem::path& data_dir);
// A static UV sphere (procedural, no data) of one material with constant kd.
Subject MakeSphereSubject();
// The samba performance, 175 frames; materials assigned by height (hair on
// top of the head, skin on the face and neck, cloth below).
absl::StatusOr<Subject> MakeSambaSubject(const std::filesystem::path& data_dir);

}  // namespace mvbrdf::synth

#endif  // MVBRDF_CORE_SYNTH_SUBJECT_H_
