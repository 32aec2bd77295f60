// What pass 1 of the reconstruction gathers per texel besides the triangle
// Samples: the sums that clustering needs and a few kept per-pixel Samples
// for the cluster fits. Gathered by RunReconstruction itself, or earlier by
// the service's gather task on the same worker (pipeline::GatherPass) and
// handed over through ReconstructOptions::texel_statistics.
#ifndef MVBRDF_CORE_PIPELINE_TEXEL_STATISTICS_H_
#define MVBRDF_CORE_PIPELINE_TEXEL_STATISTICS_H_

#include <cstdint>
#include <memory>
#include <vector>

#include <glm/glm.hpp>
#include <opencv2/core.hpp>

#include "core/pipeline/texel_illumination.h"
#include "core/pipeline/resampled_atlas_cache.h"
#include "core/pipeline/shadow_atlas_cache.h"
#include "core/pipeline/texel_reservoir.h"

namespace mvbrdf::pipeline {

struct TexelStatistics {
  std::vector<glm::dvec3> texel_sum;  // per texel, sum of observed reflectance
  std::vector<uint32_t> texel_count;
  // Per texel: its illumination sum G under each configuration the
  // reconstruction may choose, so that once the configuration is known each
  // texel's albedo estimate is sum r / G (clustering runs on it).
  TexelIllumination illumination;
  std::unique_ptr<TexelReservoir> reservoir;
  cv::Mat rest_position;  // geometry atlas of frame 0 (CV_32FC4)
  // The frames' shadow atlases as the gather computed them, for the texel
  // pass (the same frames, lights and atlas).
  std::shared_ptr<ShadowAtlasCache> shadow_atlases;
  // And its resampled atlases, for the passes after it (null when no
  // temporary file could be made: they resample again).
  std::shared_ptr<ResampledAtlasCache> resampled_atlases;
};

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_TEXEL_STATISTICS_H_
