// `mvbrdf synth`: renders a complete synthetic scene bundle with its ground
// truth, so that every later stage can be checked against what was rendered.
//
// Output layout under `out_dir`:
//   scene.json                 the Scene (paths relative to it)
//   meshes/mesh_%04d.obj       one mesh per frame (fixed connectivity)
//   videos/camN.mkv            FFV1 lossless video per camera (or
//   videos/camN/%04d.png       a PNG sequence, or camN.mp4 when lossy)
//   segments.txt               segment name per triangle (actor only)
//   ground_truth/truth.json    GroundTruth: active configuration (or
//                              per-frame lighting), lights,
//                              true cameras, materials, per-triangle
//                              material, perturbations
//   ground_truth/kd_texture.png  (spot) the true kd in UV space, sRGB
#ifndef MVBRDF_CORE_SYNTH_SYNTHESIZER_H_
#define MVBRDF_CORE_SYNTH_SYNTHESIZER_H_

#include <cstdint>
#include <filesystem>
#include <string>

#include "absl/status/statusor.h"
#include "core/brdf/model.h"
#include "core/gl/egl_context.h"
#include "core/scene/camera_model.h"
#include "mvbrdf/v1/ground_truth.pb.h"

namespace mvbrdf::synth {

enum class Preset { kActor, kSpot, kSamba, kSphere };
absl::StatusOr<Preset> ParsePreset(absl::string_view name);
const char* PresetName(Preset preset);

enum class VideoFormat { kFfv1, kPng };

// How the frames are lit. kStudio: every frame by the active configuration.
// kOlat (one light at a time): frame t by the studio's light t mod 9 alone
// (C, N, E, W, S, NE, NW, SE, SW), or with a dome by dome light t mod N,
// recorded in the scene's frame_lighting and the truth's frame_lighting.
enum class Lighting { kStudio, kOlat };

// SynthOptions::normal_detail's bumps: this times the subject's bounding
// radius (half its rest pose's box diagonal) across, world units.
inline constexpr double kNormalDetailWavelength = 0.08;
absl::StatusOr<Lighting> ParseLighting(absl::string_view name);

// "pinhole" or "orthographic" (--camera-model).
absl::StatusOr<scene::Projection> ParseCameraModel(absl::string_view name);

struct SynthOptions {
  Preset preset = Preset::kActor;
  int num_cameras = 8;
  int num_frames = 30;
  int width = 320;
  int height = 240;
  double fps = 15.0;
  // Active light configuration by name (one of the thesis's eight, e.g.
  // "NE,NW,SE,SW"; spaces are ignored). With a dome: "all" or a list of dome
  // light names ("D000,D007"). Empty: "NE,NW,SE,SW", with a dome "all".
  std::string configuration;
  // > 0: instead of the nine ceiling lights, this many directional lights
  // over the upper hemisphere (MakeDomeLights: "D000", ...), each of
  // intensity 0.8 / max(1, lights on in a frame / 4). 0: the ceiling lights.
  int dome = 0;
  // kOlat leaves `configuration` unused.
  Lighting lighting = Lighting::kStudio;
  uint32_t seed = 1;
  VideoFormat video_format = VideoFormat::kFfv1;
  // Perturbations (ground_truth.proto: Perturbations).
  double noise_sigma = 1.0;           // 8-bit code values
  double camera_rotation_error_deg = 0.0;
  double camera_translation_error = 0.0;
  double vertex_noise = 0.0;          // world units
  bool lossy_video = false;
  double exposure = 1.0;
  double distortion_k1 = 0.0;
  // Samples per pixel along each axis (ground_truth.proto: pixel_samples):
  // 1 renders one sample at each pixel centre, N averages N x N in linear
  // light, as a camera's pixel integrates over its area.
  int pixel_samples = 1;
  // Issue #18: surface detail below the mesh's resolution, the peak slope of
  // a procedural tangent-space normal (render/normal_detail.h) in bumps of
  // kNormalDetailWavelength x the subject's bounding radius; 0: none. A
  // subject without UVs gets an atlas's (atlas::BuildAtlas, default options)
  // for its tangent frames, written into the meshes.
  double normal_detail = 0.0;
  // The reflectance model rendered (model_materials.h converts the presets'
  // materials; recorded in truth.json's brdf and materials).
  brdf::Model brdf = brdf::Model::kPhong;
  // Issue #15: measured materials for some slots (measured_materials.h's
  // spec, e.g. "cloth=blue-fabric,skin=-,hair=black-oxidized-steel"),
  // from `merl_file` (a merl_nbrdf.json; empty: DefaultMerlFile). Recorded
  // in truth.json's materials (measured, measured_weights).
  std::string materials;
  std::filesystem::path merl_file;
  // How a measured material is exposed (MeasuredGain): kAlbedo gives it the
  // slot's albedo (its highlights clip as a glossy surface's do in an
  // 8-bit capture exposed for the diffuse); kHighlights keeps its brightest
  // highlight under the brightest light below clipping (with 16-bit frames
  // the diffuse stays well quantised).
  enum class MeasuredExposure { kAlbedo, kHighlights };
  MeasuredExposure measured_exposure = MeasuredExposure::kAlbedo;
  // Bits per channel of the stored frames: 8, or 16 (PNG sequences only).
  int bit_depth = 8;
  // Issue #14: the lights written to scene.json differ from the rendered
  // ones (truth.lights): each point light moved by this distance in a random
  // direction, each directional light turned by light_direction_error_deg
  // about a random axis, each intensity scaled by 1 + or - this fraction
  // (random sign, all channels alike). Their own random stream (of `seed`):
  // the images are those of the unperturbed scene.
  double light_position_error = 0.0;  // world units
  double light_direction_error_deg = 0.0;
  double light_intensity_error = 0.0;  // relative, < 1
  // Pinhole or orthographic cameras (StudioOptions::projection); an
  // orthographic camera has no distortion.
  scene::Projection camera_model = scene::Projection::kPinhole;
  // Actor tessellation (ActorOptions::segments).
  int actor_segments = 24;
  int shadow_map_size = 1024;
  // Where the spot and samba data live (../shared/data from the repository).
  std::filesystem::path data_dir;
  std::filesystem::path out_dir;

  // Checks ranges; errors name the option ("--cameras: must be in [1, 64], got 0").
  absl::Status Check() const;
};

struct SynthResult {
  std::filesystem::path scene_file;
  v1::GroundTruth truth;
  int num_triangles = 0;
  int frames_rendered = 0;
  double seconds = 0.0;
};

absl::StatusOr<SynthResult> Synthesize(const SynthOptions& options, gl::EglContext& context);

}  // namespace mvbrdf::synth

#endif  // MVBRDF_CORE_SYNTH_SYNTHESIZER_H_
