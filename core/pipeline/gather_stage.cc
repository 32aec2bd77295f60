#include "core/pipeline/gather_stage.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "core/atlas/atlas.h"
#include "core/base/status_macros.h"
#include "core/pipeline/frame_stream.h"
#include "core/resample/atlas_ops.h"
#include "core/samples/assemble.h"

namespace mvbrdf::pipeline {

absl::StatusOr<samples::SampleSet> GatherTriangleSamples(const scene::Sequence& sequence, gl::EglContext& context,
                                                         const ReconstructOptions& options) {
  if (sequence.lights.size() > static_cast<size_t>(samples::kMaxLights)) {
    return absl::InvalidArgumentError(absl::StrCat("scene.lights: at most ", samples::kMaxLights, " lights, got ",
                                                   sequence.lights.size()));
  }
  samples::AssembleOptions assemble = options.assemble;
  assemble.inverse_square_falloff = sequence.scene.lighting().inverse_square_falloff();
  MVBRDF_ASSIGN_OR_RETURN(const atlas::Atlas atlas,
                          atlas::BuildAtlas(sequence.topology, sequence.rest_positions, options.atlas));
  samples::SampleSet set = samples::MakeSampleSet(sequence.lights);
  MVBRDF_ASSIGN_OR_RETURN(auto stream, FrameStream::Open(sequence, context, atlas, options.resampler));
  const int stride = std::max(options.sweep_frame_stride, 1);
  for (int t = 0; t < sequence.num_frames; t += stride) {
    if (options.progress) options.progress("gather_samples", t, sequence.num_frames);
    MVBRDF_RETURN_IF_ERROR(CheckCancelled(options));
    MVBRDF_RETURN_IF_ERROR(stream->SetFrame(t));
    for (int c = 0; c < static_cast<int>(sequence.cameras.size()); ++c) {
      MVBRDF_ASSIGN_OR_RETURN(const cv::Mat resampled, stream->Resample(c));
      const auto means = resample::AverageTriangles(resampled, atlas, options.min_valid_fraction);
      samples::AppendTriangleSamples(means, atlas, stream->positions(), stream->shadows(), sequence.cameras[c], c, t,
                                     sequence.lights, assemble, &set);
    }
  }
  if (options.progress) options.progress("gather_samples", sequence.num_frames, sequence.num_frames);
  return set;
}

}  // namespace mvbrdf::pipeline
