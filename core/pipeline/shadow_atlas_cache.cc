#include "core/pipeline/shadow_atlas_cache.h"

#include <zlib.h>

namespace mvbrdf::pipeline {

std::optional<cv::Mat> ShadowAtlasCache::Find(int t, const std::string& lights) const {
  const auto it = frames_.find(t);
  if (it == frames_.end() || it->second.lights != lights) return std::nullopt;
  const Entry& e = it->second;
  cv::Mat atlas(e.rows, e.cols, e.type);
  uLongf size = static_cast<uLongf>(atlas.total() * atlas.elemSize());
  if (uncompress(atlas.data, &size, e.compressed.data(), static_cast<uLong>(e.compressed.size())) != Z_OK ||
      size != atlas.total() * atlas.elemSize()) {
    return std::nullopt;  // cannot happen for what Keep stored; recomputed then
  }
  return atlas;
}

void ShadowAtlasCache::Keep(int t, const std::string& lights, const cv::Mat& atlas) {
  if (frames_.count(t) != 0 || !atlas.isContinuous() || atlas.empty()) return;
  const uLong raw = static_cast<uLong>(atlas.total() * atlas.elemSize());
  uLongf size = compressBound(raw);
  Entry e;
  e.lights = lights;
  e.rows = atlas.rows;
  e.cols = atlas.cols;
  e.type = atlas.type();
  e.compressed.resize(size);
  // Level 1: the fastest; the atlas is mostly runs of equal words.
  if (compress2(e.compressed.data(), &size, atlas.data, raw, 1) != Z_OK) return;
  e.compressed.resize(size);
  e.compressed.shrink_to_fit();
  if (size + lights.size() > budget_bytes_ - bytes_) return;
  bytes_ += size + lights.size();
  frames_.emplace(t, std::move(e));
}

}  // namespace mvbrdf::pipeline
