// CPU operations on resampled atlases (CV_32FC4, rgb + validity in a):
// growing for rendering (thesis §5.1.2) and per-triangle averaging for light
// estimation (§5.1.3).
#ifndef MVBRDF_CORE_RESAMPLE_ATLAS_OPS_H_
#define MVBRDF_CORE_RESAMPLE_ATLAS_OPS_H_

#include <glm/glm.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "core/atlas/atlas.h"

namespace mvbrdf::resample {

// Dilation by `iterations`: in each, every invalid texel with at least one
// valid 8-neighbour takes the mean of those neighbours and becomes valid.
// All texels of an iteration read the previous iteration's atlas (one ring
// per iteration). Valid means a > 0.5; grown texels get a = 1. Returns a new
// image; `rgba` (CV_32FC4) is not modified. Pure function; any thread.
cv::Mat GrowAtlas(const cv::Mat& rgba, int iterations);

struct TriangleMean {
  glm::vec3 rgb{0.0f};  // mean of the valid texels of the triangle
  int valid_texels = 0;
  int texels = 0;      // atlas.triangle_texels[t].size()
  bool valid = false;  // valid_texels >= min_valid_fraction * texels (and > 0)
};

// Mean of each triangle's valid texels. A triangle counts as seen only when at
// least `min_valid_fraction` of its texels are valid: partly hidden triangles
// sit at silhouettes and occlusion boundaries, where resampling is least
// reliable.
std::vector<TriangleMean> AverageTriangles(const cv::Mat& rgba, const atlas::Atlas& atlas,
                                           float min_valid_fraction = 0.75f);

// The averaged atlas (thesis Fig. 5.5): every texel of a valid triangle holds
// its mean with a = 1; others a = 0. A triangle without an interior texel
// (atlas.h: it is given the texel under its UV centroid, owned by another
// triangle) writes that texel only when its owner is not valid.
cv::Mat AveragedAtlas(const std::vector<TriangleMean>& means, const atlas::Atlas& atlas);

}  // namespace mvbrdf::resample

#endif  // MVBRDF_CORE_RESAMPLE_ATLAS_OPS_H_
