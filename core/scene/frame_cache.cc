#include "core/scene/frame_cache.h"

namespace mvbrdf::scene {

std::optional<FramePositions> FrameCache::Find(const std::string& key) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = frames_.find(key);
  if (it == frames_.end()) return std::nullopt;
  return it->second;
}

void FrameCache::Keep(const std::string& key, const FramePositions& positions) {
  const size_t bytes = positions.size() * sizeof(glm::vec3) + key.size();
  std::lock_guard<std::mutex> lock(mutex_);
  if (frames_.count(key) != 0 || bytes > budget_bytes_ - bytes_) return;
  frames_.emplace(key, positions);
  bytes_ += bytes;
}

size_t FrameCache::bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return bytes_;
}

size_t FrameCache::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return frames_.size();
}

}  // namespace mvbrdf::scene
