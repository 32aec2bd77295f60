// The resampled atlases of a job's first pass over the frames, one per
// (frame, camera), for the passes after it (the normals stage's, the texel
// pass): the same frame, camera, calibration and resampler options give the
// same atlas, and resampling it again (decoding the video frame, the camera's
// depth map, the per-texel shader and its read-back: ~35 ms per (frame,
// camera) at 512^2 on llvmpipe) costs far more than reading it back.
// Kept bit for bit (the texels that are not all zero, float32, in runs) in an
// unlinked temporary file under TMPDIR, so that the process's memory does not
// grow with the sequence (the page cache holds it while RAM allows); within a
// byte budget, at most half the file system's free space at creation. A
// write that fails keeps nothing more; what was kept stays readable.
// One per job (the texel pass keeps its per-frame observed kd atlases in one
// more); any thread (one call at a time).
#ifndef MVBRDF_CORE_PIPELINE_RESAMPLED_ATLAS_CACHE_H_
#define MVBRDF_CORE_PIPELINE_RESAMPLED_ATLAS_CACHE_H_

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "core/resample/resampler.h"

namespace mvbrdf::pipeline {

class ResampledAtlasCache {
 public:
  static constexpr size_t kDefaultBudgetBytes = size_t{16} << 30;

  // The file in `dir` (empty: base::TemporaryDirectory(), TMPDIR's), created
  // and unlinked at once: nothing is left behind, even by a process that is
  // killed. The budget: at most `budget_bytes` and half the file system's free
  // space now; a job's second cache takes the first's budget_left().
  static absl::StatusOr<std::unique_ptr<ResampledAtlasCache>> Create(size_t budget_bytes = kDefaultBudgetBytes,
                                                                     const std::string& dir = "");
  ~ResampledAtlasCache();
  ResampledAtlasCache(const ResampledAtlasCache&) = delete;
  ResampledAtlasCache& operator=(const ResampledAtlasCache&) = delete;

  struct Kept {
    cv::Mat atlas;  // CV_32FC4, as kept
    // What resampling it refused (Resampler::Refused's increase), so that a
    // pass served from here counts what a pass that resampled would have.
    resample::Resampler::RefusedObservations refused;
  };
  // The atlas kept for (t, camera) under `key` (what it was computed from
  // besides the frame: the camera's model, the resampler's options), if any;
  // none also where the file cannot be read back (an I/O error).
  std::optional<Kept> Find(int t, int camera, const std::string& key) const;
  // Whether an atlas is kept for (t, camera) under `key` (Find then fails
  // only on an I/O error).
  bool Contains(int t, int camera, const std::string& key) const;
  // Keeps it (a continuous CV_32FC4 atlas) once, while the budget allows;
  // whether it is kept now.
  bool Keep(int t, int camera, const std::string& key, const cv::Mat& atlas,
            const resample::Resampler::RefusedObservations& refused = {});

  size_t bytes() const;
  size_t budget_left() const;  // 0 once a write failed
  size_t size() const;

 private:
  ResampledAtlasCache(int fd, size_t budget_bytes) : fd_(fd), budget_bytes_(budget_bytes) {}
  struct Entry {
    std::string key;
    int rows = 0, cols = 0;
    uint64_t offset = 0;  // in the file: runs (begin, length) as uint32 pairs, then the texels
    uint32_t runs = 0;
    uint64_t texels = 0;
    resample::Resampler::RefusedObservations refused;
  };
  mutable std::mutex mutex_;  // guards what follows
  int fd_;
  const size_t budget_bytes_;
  bool failed_ = false;  // a write failed: keep nothing more
  std::map<std::pair<int, int>, Entry> entries_;
  // Keep's and Find's buffers, kept between calls: an atlas's worth of
  // allocations freed per call would leave the heap fragmented.
  mutable std::vector<uint32_t> runs_;
  mutable std::vector<cv::Vec4f> texels_;
  size_t bytes_ = 0;
};

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_RESAMPLED_ATLAS_CACHE_H_
