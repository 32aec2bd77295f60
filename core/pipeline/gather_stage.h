// The service's `gather` task (docs/service.md): pass 1 of the
// reconstruction reduced to what the light sweep needs — the triangle Samples
// (triangle-averaged atlases, every scene light) of every sweep frame. The
// Samples equal those RunReconstruction gathers for its own sweep with the
// same options, so a sweep over them chooses alike.
#ifndef MVBRDF_CORE_PIPELINE_GATHER_STAGE_H_
#define MVBRDF_CORE_PIPELINE_GATHER_STAGE_H_

#include "absl/status/statusor.h"
#include "core/gl/egl_context.h"
#include "core/pipeline/reconstruct_stage.h"
#include "core/samples/sample_set.h"
#include "core/scene/sequence.h"

namespace mvbrdf::pipeline {

// Uses options.atlas, resampler, assemble, min_valid_fraction,
// sweep_frame_stride and progress (stage "gather_samples").
absl::StatusOr<samples::SampleSet> GatherTriangleSamples(const scene::Sequence& sequence, gl::EglContext& context,
                                                         const ReconstructOptions& options);

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_GATHER_STAGE_H_
