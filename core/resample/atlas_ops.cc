#include "core/resample/atlas_ops.h"

#include <cstdio>
#include <cstdlib>

namespace mvbrdf::resample {
namespace {

// Programmer invariants (wrong image type or atlas): abort with a message.
void Check(bool condition, const char* message) {
  if (condition) return;
  std::fprintf(stderr, "core/resample/atlas_ops.cc: %s\n", message);
  std::abort();
}

// Validity of a texel of a resampled atlas: a is 1 (valid) or 0 (invalid);
// anything above one half counts as valid.
inline bool IsValid(const cv::Vec4f& texel) { return texel[3] > 0.5f; }

}  // namespace

cv::Mat GrowAtlas(const cv::Mat& rgba, int iterations) {
  Check(rgba.type() == CV_32FC4, "GrowAtlas: expects a CV_32FC4 atlas");
  cv::Mat current = rgba.clone();
  cv::Mat next = current.clone();
  const int rows = rgba.rows, cols = rgba.cols;
  for (int it = 0; it < iterations; ++it) {
    // Every iteration reads only `current`, so a texel grown in this iteration
    // does not feed its neighbours until the next one (one ring per iteration).
    bool changed = false;
    for (int y = 0; y < rows; ++y) {
      const cv::Vec4f* row = current.ptr<cv::Vec4f>(y);
      cv::Vec4f* out = next.ptr<cv::Vec4f>(y);
      for (int x = 0; x < cols; ++x) {
        out[x] = row[x];
        if (IsValid(row[x])) continue;
        cv::Vec3f sum(0.0f, 0.0f, 0.0f);
        int count = 0;
        for (int dy = -1; dy <= 1; ++dy) {
          const int yy = y + dy;
          if (yy < 0 || yy >= rows) continue;
          const cv::Vec4f* neighbours = current.ptr<cv::Vec4f>(yy);
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = x + dx;
            if ((dx == 0 && dy == 0) || xx < 0 || xx >= cols) continue;
            const cv::Vec4f& n = neighbours[xx];
            if (!IsValid(n)) continue;
            sum += cv::Vec3f(n[0], n[1], n[2]);
            ++count;
          }
        }
        if (count == 0) continue;
        sum /= static_cast<float>(count);
        out[x] = cv::Vec4f(sum[0], sum[1], sum[2], 1.0f);
        changed = true;
      }
    }
    std::swap(current, next);
    if (!changed) break;
  }
  return current;
}

std::vector<TriangleMean> AverageTriangles(const cv::Mat& rgba, const atlas::Atlas& atlas, float min_valid_fraction) {
  Check(rgba.type() == CV_32FC4, "AverageTriangles: expects a CV_32FC4 atlas");
  Check(rgba.rows == atlas.size && rgba.cols == atlas.size, "AverageTriangles: image size is not the atlas size");
  std::vector<TriangleMean> means(atlas.triangle_texels.size());
  for (size_t t = 0; t < means.size(); ++t) {
    TriangleMean& m = means[t];
    const std::vector<uint32_t>& texels = atlas.triangle_texels[t];
    m.texels = static_cast<int>(texels.size());
    // Double accumulation: a large triangle sums thousands of texels.
    double sum[3] = {0.0, 0.0, 0.0};
    for (uint32_t index : texels) {
      const cv::Vec4f& texel =
          rgba.at<cv::Vec4f>(static_cast<int>(index / atlas.size), static_cast<int>(index % atlas.size));
      if (!IsValid(texel)) continue;
      for (int c = 0; c < 3; ++c) sum[c] += texel[c];
      ++m.valid_texels;
    }
    if (m.valid_texels > 0) {
      m.rgb = glm::vec3(static_cast<float>(sum[0] / m.valid_texels), static_cast<float>(sum[1] / m.valid_texels),
                        static_cast<float>(sum[2] / m.valid_texels));
    }
    m.valid =
        m.valid_texels > 0 && static_cast<double>(m.valid_texels) >= static_cast<double>(min_valid_fraction) * m.texels;
  }
  return means;
}

cv::Mat AveragedAtlas(const std::vector<TriangleMean>& means, const atlas::Atlas& atlas) {
  Check(means.size() == atlas.triangle_texels.size(), "AveragedAtlas: expects one mean per triangle");
  cv::Mat out(atlas.size, atlas.size, CV_32FC4, cv::Scalar(0, 0, 0, 0));
  const bool has_ids = atlas.triangle_id.rows == atlas.size && atlas.triangle_id.cols == atlas.size;
  // Texels a triangle owns (triangle_id) first; then the stand-in texel of a
  // triangle too small to hold a texel centre (atlas.h), only where no valid
  // owner has written, so that a sliver never overwrites its neighbour's mean.
  for (int pass = 0; pass < 2; ++pass) {
    for (size_t t = 0; t < means.size(); ++t) {
      const TriangleMean& m = means[t];
      if (!m.valid) continue;
      for (uint32_t index : atlas.triangle_texels[t]) {
        const int y = static_cast<int>(index / atlas.size), x = static_cast<int>(index % atlas.size);
        const bool owned = !has_ids || atlas.triangle_id.at<int32_t>(y, x) == static_cast<int32_t>(t);
        cv::Vec4f& texel = out.at<cv::Vec4f>(y, x);
        if (pass == 0 && owned) {
          texel = cv::Vec4f(m.rgb.x, m.rgb.y, m.rgb.z, 1.0f);
        } else if (pass == 1 && !owned && !IsValid(texel)) {
          texel = cv::Vec4f(m.rgb.x, m.rgb.y, m.rgb.z, 1.0f);
        }
      }
    }
  }
  return out;
}

}  // namespace mvbrdf::resample
