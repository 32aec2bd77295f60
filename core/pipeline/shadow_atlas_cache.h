// The shadow atlases of a job's frames, computed by its first pass over the
// frames and reused by the next (the light sweep's gather, the texel pass):
// the same frame, lights and atlas give the same atlas, and it costs more to
// render (each light's shadow map, then the test per texel: ~100 ms per frame
// of 9 lights on a 24 k-triangle mesh) than to keep. Kept compressed (zlib
// level 1: 512 KB -> ~44 KB per 512^2 frame of the thesis-scale actor, 12x)
// within a byte budget.
// One per job (one set of resampler options); not thread-safe: a job's
// passes run one after the other.
#ifndef MVBRDF_CORE_PIPELINE_SHADOW_ATLAS_CACHE_H_
#define MVBRDF_CORE_PIPELINE_SHADOW_ATLAS_CACHE_H_

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace mvbrdf::pipeline {

class ShadowAtlasCache {
 public:
  static constexpr size_t kDefaultBudgetBytes = size_t{64} << 20;

  explicit ShadowAtlasCache(size_t budget_bytes = kDefaultBudgetBytes) : budget_bytes_(budget_bytes) {}

  // The atlas kept for frame t under `lights` (what it was computed from:
  // the lights' positions and directions, which light refinement changes
  // between passes), if any; a new matrix.
  std::optional<cv::Mat> Find(int t, const std::string& lights) const;
  // Keeps frame t's atlas (continuous) when its compressed bytes fit the
  // budget's remainder; nothing is evicted, a frame is kept once.
  void Keep(int t, const std::string& lights, const cv::Mat& atlas);

  size_t bytes() const { return bytes_; }
  size_t size() const { return frames_.size(); }

 private:
  struct Entry {
    std::string lights;
    int rows = 0, cols = 0, type = 0;
    std::vector<unsigned char> compressed;
  };
  const size_t budget_bytes_;
  std::map<int, Entry> frames_;
  size_t bytes_ = 0;
};

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_SHADOW_ATLAS_CACHE_H_
