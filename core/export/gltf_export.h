// A reconstruction (the output directory of `mvbrdf run`) written as glTF 2.0
// (issue #16), with Debian's tinygltf: `mvbrdf export RUN --out model.glb`.
//
// What it holds:
//   - the mesh with the atlas UVs (glTF's v = 1 - the atlas's v), in the rest
//     pose or the pose of one frame, smooth normals as the renderer's;
//   - one material, glTF's metallic-roughness with KHR_materials_specular, its
//     textures per texel from the run's atlases: every texel's lobe as GGX
//     (brdf::GgxEquivalent: exact for GGX, a width and peak match for Phong
//     and Blinn-Phong), metallic 0; ggx.h's model F = F0 (0.04 + 0.96 w) /
//     0.04 is KHR_materials_specular's with ior 1.5, specularFactor = F90 =
//     F0 / 0.04 (the specular texture's alpha, per texel the largest channel's)
//     and specularColor = F0 / (0.04 F90) per channel;
//       baseColor (sRGB) = pi kd' s, with kd' = kd 0.96 / (1 - 0.04 F90 s) so
//     that glTF's diffuse weight 1 - F90 s (0.04 + 0.96 w) gives ggx.h's
//     0.96 (1 - w) kd head on (exact at w = 0, and wherever F90 s = 1);
//       metallicRoughness (linear): G = roughness, B = metallic = 0;
//   - one scale s for the whole export (materials x s, lights / s, so that a
//     viewer draws the same radiance): the largest s keeping baseColor and
//     specularFactor <= 1 over the observed texels (99.9th percentile;
//     brighter ones clip), kept in the asset's extras (`mvbrdf.scale`);
//   - the confidence atlas (observations per texel / the maximum) as an extra
//     texture named in the material's extras (`mvbrdf.confidenceTexture`):
//     Kintsugi-style documentation of what was seen;
//   - the scene's cameras (perspective; glTF looks down -z with +y up, the
//     scene's cameras down +z with +y down) and lights (KHR_lights_punctual:
//     point lights in candela with inverse-square fall-off, directional in
//     lux; intensity / s, colour the intensity's RGB over its largest).
#ifndef MVBRDF_CORE_EXPORT_GLTF_EXPORT_H_
#define MVBRDF_CORE_EXPORT_GLTF_EXPORT_H_

#include <filesystem>

#include "absl/status/statusor.h"
#include "core/scene/sequence.h"

namespace mvbrdf::exporter {

struct GltfExportOptions {
  // The pose: -1 the rest pose (frame 0), else a frame of the sequence.
  int frame = -1;
  // The tracked motion: the rest pose with one morph target per frame (its
  // positions' and normals' offsets), and an animation of the mesh's weights
  // that shows frame t alone from t / fps seconds on (STEP), named
  // "frame NNNN" (absolute frame numbers) in the mesh's extras.targetNames.
  // Not with `frame` >= 0.
  bool animation = false;
};

struct GltfExportSummary {
  double scale = 1.0;   // s above
  int vertices = 0, triangles = 0, cameras = 0, lights = 0;
  int morph_targets = 0;  // frames with --animation
  int texture_size = 0;
  double clipped_fraction = 0.0;  // observed texels whose baseColor or specularFactor clipped at 1
  // The scene has point lights that do not fall off with distance (glTF's
  // always do: inverse square), so a viewer draws them differently.
  bool point_lights_without_falloff = false;
};

// Writes `out` from the run in `run_dir` whose scene `sequence` is: GLB (one
// binary file) when it ends in .glb, glTF (JSON with the buffers and images
// embedded as data URIs) when in .gltf. Errors
// name the file or field: INVALID_ARGUMENT for a bad frame or extension,
// FAILED_PRECONDITION for a run whose atlases do not match its scene.
absl::StatusOr<GltfExportSummary> ExportGltf(const std::filesystem::path& run_dir, const scene::Sequence& sequence,
                                             const std::filesystem::path& out, const GltfExportOptions& options);

}  // namespace mvbrdf::exporter

#endif  // MVBRDF_CORE_EXPORT_GLTF_EXPORT_H_
