// CPU rasterisation of the atlas layout: which triangle owns each texel centre.
#include <algorithm>
#include <cmath>

#include "core/atlas/atlas.h"

namespace mvbrdf::atlas {
namespace {

// Texel-centre coordinates: texel (i, j) is at (i, j); u, v in [0, 1].
glm::dvec2 ToTexelSpace(const glm::vec2& uv, int size) {
  return {static_cast<double>(uv.x) * size - 0.5, (1.0 - static_cast<double>(uv.y)) * size - 0.5};
}

double Edge(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& p) {
  return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
}

// Half-open rule for points exactly on an edge: of the two triangles sharing
// the edge (traversing it in opposite directions), exactly one accepts it.
bool AcceptsOnEdge(const glm::dvec2& a, const glm::dvec2& b) {
  const double dy = b.y - a.y, dx = b.x - a.x;
  return dy > 0.0 || (dy == 0.0 && dx < 0.0);
}

}  // namespace

void RasterizeTriangles(Atlas* atlas) {
  const int size = atlas->size;
  const scene::MeshTopology& topo = atlas->topology;
  atlas->triangle_id = cv::Mat(size, size, CV_32SC1, cv::Scalar(-1));
  atlas->triangle_texels.assign(topo.triangles.size(), {});
  std::vector<uint8_t> zero_area(topo.triangles.size(), 0);
  for (uint32_t t : topo.zero_area_triangles) zero_area[t] = 1;

  int64_t claimed_twice = 0;
  int64_t covered = 0;
  int without_interior = 0;
  for (size_t t = 0; t < topo.triangles.size(); ++t) {
    glm::dvec2 p[3];
    for (int k = 0; k < 3; ++k) p[k] = ToTexelSpace(topo.uvs[topo.triangles[t][k]], size);
    // Orient so that the edge functions of interior points are positive.
    if (Edge(p[0], p[1], p[2]) < 0.0) std::swap(p[1], p[2]);
    const double area2 = Edge(p[0], p[1], p[2]);
    std::vector<uint32_t>& texels = atlas->triangle_texels[t];
    if (area2 > 0.0) {
      const int x0 = std::max(0, static_cast<int>(std::ceil(std::min({p[0].x, p[1].x, p[2].x}))));
      const int x1 = std::min(size - 1, static_cast<int>(std::floor(std::max({p[0].x, p[1].x, p[2].x}))));
      const int y0 = std::max(0, static_cast<int>(std::ceil(std::min({p[0].y, p[1].y, p[2].y}))));
      const int y1 = std::min(size - 1, static_cast<int>(std::floor(std::max({p[0].y, p[1].y, p[2].y}))));
      for (int y = y0; y <= y1; ++y) {
        int32_t* row = atlas->triangle_id.ptr<int32_t>(y);
        for (int x = x0; x <= x1; ++x) {
          const glm::dvec2 c(x, y);
          bool inside = true;
          for (int k = 0; k < 3 && inside; ++k) {
            const glm::dvec2& a = p[k];
            const glm::dvec2& b = p[(k + 1) % 3];
            const double e = Edge(a, b, c);
            inside = e > 0.0 || (e == 0.0 && AcceptsOnEdge(a, b));
          }
          if (!inside) continue;
          texels.push_back(static_cast<uint32_t>(y * size + x));
          if (row[x] < 0) {
            row[x] = static_cast<int32_t>(t);
            ++covered;
          } else {
            ++claimed_twice;
          }
        }
      }
    }
    if (texels.empty()) {
      if (!zero_area[t]) ++without_interior;
      const glm::vec2 centroid =
          (topo.uvs[topo.triangles[t].x] + topo.uvs[topo.triangles[t].y] + topo.uvs[topo.triangles[t].z]) / 3.0f;
      const int x = std::clamp(static_cast<int>(std::floor(centroid.x * size)), 0, size - 1);
      const int y = std::clamp(static_cast<int>(std::floor((1.0f - centroid.y) * size)), 0, size - 1);
      texels.push_back(static_cast<uint32_t>(y * size + x));
    }
  }
  atlas->stats.coverage = static_cast<double>(covered) / (static_cast<double>(size) * size);
  atlas->stats.overlap_fraction = covered > 0 ? static_cast<double>(claimed_twice) / static_cast<double>(covered) : 0.0;
  atlas->stats.triangles_without_interior_texels = without_interior;
}

}  // namespace mvbrdf::atlas
