// The frames of a sequence's mesh read so far, kept while they fit a byte
// budget: a job reads each frame's file in several passes (the light sweep's
// gather, the texel pass, camera refinement, relighting), and importing a
// mesh file (a forked assimp process, core/scene/mesh_loader.h) costs more
// than the frame's resampling. Thread-safe; shared by copies of a Sequence.
#ifndef MVBRDF_CORE_SCENE_FRAME_CACHE_H_
#define MVBRDF_CORE_SCENE_FRAME_CACHE_H_

#include <cstddef>
#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "core/scene/mesh.h"

namespace mvbrdf::scene {

class FrameCache {
 public:
  // Enough for the thesis's scale (400 frames of a 12 k-vertex mesh: 58 MB)
  // and samba's 175 frames, well inside a job's memory estimate.
  static constexpr size_t kDefaultBudgetBytes = size_t{256} << 20;

  explicit FrameCache(size_t budget_bytes = kDefaultBudgetBytes) : budget_bytes_(budget_bytes) {}

  // The positions kept under `key` (e.g. the file's path), if any.
  std::optional<FramePositions> Find(const std::string& key) const;
  // Keeps `positions` under `key` when they fit the budget's remainder
  // (first come, first kept: nothing is evicted).
  void Keep(const std::string& key, const FramePositions& positions);

  size_t bytes() const;
  size_t size() const;

 private:
  const size_t budget_bytes_;
  mutable std::mutex mutex_;
  std::map<std::string, FramePositions> frames_;
  size_t bytes_ = 0;
};

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_FRAME_CACHE_H_
