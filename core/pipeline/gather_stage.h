// Pass 1 of the reconstruction: every frame resampled into the atlas once,
// for the triangle Samples of the light sweep (triangle-averaged atlases,
// every scene light) and the per-texel statistics of clustering and the
// cluster fits. RunReconstruction runs it; so does the service's `gather`
// task (docs/service.md), whose Samples are therefore those a one-process
// run sweeps over.
#ifndef MVBRDF_CORE_PIPELINE_GATHER_STAGE_H_
#define MVBRDF_CORE_PIPELINE_GATHER_STAGE_H_

#include "absl/status/statusor.h"
#include "core/atlas/atlas.h"
#include "core/gl/egl_context.h"
#include "core/pipeline/reconstruct_stage.h"
#include "core/pipeline/shadow_atlas_cache.h"
#include "core/pipeline/texel_reservoir.h"
#include "core/pipeline/texel_statistics.h"
#include "core/samples/sample_set.h"
#include "core/scene/sequence.h"

namespace mvbrdf::pipeline {

struct Gathered {
  samples::SampleSet triangle_samples;         // empty unless `triangles`
  std::shared_ptr<TexelStatistics> texels;     // null unless `texels`
  cv::Mat rest_position;                       // geometry atlas of frame 0 when it was read
};

// Pass 1 over the frames on `atlas` (built with options.atlas): the triangle
// Samples of every sweep frame when `triangles`, the texel statistics over
// every frame when `texels`. RunReconstruction's pass 1 is this call. Uses
// options.resampler, assemble, min_valid_fraction, sweep_frame_stride,
// reservoir_*, progress (stage "gather_samples") and cancelled. With
// `texels`, the frames' shadow atlases are kept for the texel pass
// (TexelStatistics::shadow_atlases).
absl::StatusOr<Gathered> GatherPass(const scene::Sequence& sequence, gl::EglContext& context,
                                    const atlas::Atlas& atlas, const ReconstructOptions& options, bool triangles,
                                    bool texels);

// Issue #18: the cluster fits' per-pixel Samples gathered again over every
// frame, read with refined normals (per texel tangent-space `tangent_normals`
// where `refined` is 1; FrameStream::UseNormals), into a reservoir of
// GatherPass's shape. `shadows`: pass 1's shadow atlases (may be null).
absl::StatusOr<std::unique_ptr<TexelReservoir>> GatherPixelSamples(const scene::Sequence& sequence,
                                                                   gl::EglContext& context, const atlas::Atlas& atlas,
                                                                   const ReconstructOptions& options,
                                                                   ShadowAtlasCache* shadows,
                                                                   const std::vector<glm::vec3>& tangent_normals,
                                                                   const std::vector<uint8_t>& refined);

// INVALID_ARGUMENT naming options.pixel_footprint when its copies of the
// scene's `num_lights` lights (footprint^2 each, samples::FootprintLights)
// would exceed samples::kMaxLights. GatherPass and RunReconstruction check it.
absl::Status CheckPixelFootprint(int pixel_footprint, size_t num_lights);

// Appends to the plan's light_sweep stage which frames it uses, when not all.
void NoteSweepFrames(const ReconstructOptions& options, int num_frames, v1::Plan* plan);

// The atlas of options.atlas, then GatherPass for the triangle Samples only.
absl::StatusOr<samples::SampleSet> GatherTriangleSamples(const scene::Sequence& sequence, gl::EglContext& context,
                                                         const ReconstructOptions& options);

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_GATHER_STAGE_H_
