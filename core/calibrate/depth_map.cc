#include "core/calibrate/depth_map.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mvbrdf::calibrate {

DepthMap RenderDepth(const scene::CameraModel& camera, const std::vector<glm::uvec3>& triangles,
                     const scene::FramePositions& positions) {
  DepthMap map;
  map.width = camera.width;
  map.height = camera.height;
  const size_t n = static_cast<size_t>(map.width) * static_cast<size_t>(map.height);
  map.depth.assign(n, std::numeric_limits<float>::infinity());
  map.triangle.assign(n, -1);
  std::vector<glm::dvec3> projected(positions.size());  // (u, v, z)
  for (size_t i = 0; i < positions.size(); ++i) {
    const glm::dvec3 p(positions[i]);
    const double z = camera.CamFromWorld(p).z;
    const glm::dvec2 uv = camera.Project(p);
    projected[i] = glm::dvec3(uv, z);
  }
  for (size_t t = 0; t < triangles.size(); ++t) {
    const glm::dvec3 a = projected[triangles[t].x], b = projected[triangles[t].y], c = projected[triangles[t].z];
    if (!(a.z > 0) || !(b.z > 0) || !(c.z > 0)) continue;
    const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (!(std::abs(area) > 1e-12)) continue;
    const int x0 = std::max(0, static_cast<int>(std::ceil(std::min({a.x, b.x, c.x}))));
    const int x1 = std::min(map.width - 1, static_cast<int>(std::floor(std::max({a.x, b.x, c.x}))));
    const int y0 = std::max(0, static_cast<int>(std::ceil(std::min({a.y, b.y, c.y}))));
    const int y1 = std::min(map.height - 1, static_cast<int>(std::floor(std::max({a.y, b.y, c.y}))));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const double w0 = ((b.x - x) * (c.y - y) - (b.y - y) * (c.x - x)) / area;
        const double w1 = ((c.x - x) * (a.y - y) - (c.y - y) * (a.x - x)) / area;
        const double w2 = 1.0 - w0 - w1;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        const float z = static_cast<float>(w0 * a.z + w1 * b.z + w2 * c.z);
        const size_t i = static_cast<size_t>(y) * map.width + x;
        if (z < map.depth[i]) {
          map.depth[i] = z;
          map.triangle[i] = static_cast<int>(t);
        }
      }
    }
  }
  return map;
}

bool VisibleAt(const DepthMap& map, const glm::dvec2& uv, double z, double relative_tolerance) {
  if (!(uv.x >= 0) || !(uv.y >= 0)) return false;
  const int x = static_cast<int>(std::lround(uv.x)), y = static_cast<int>(std::lround(uv.y));
  if (!map.Inside(x, y)) return false;
  // Nearest z-buffer depth in the 3x3 neighbourhood: a point on a triangle
  // edge may land on the neighbour's pixel centre.
  double best = std::numeric_limits<double>::infinity();
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      if (!map.Inside(x + dx, y + dy)) continue;
      best = std::min(best, std::abs(static_cast<double>(map.At(x + dx, y + dy)) - z));
    }
  }
  return best <= relative_tolerance * z;
}

}  // namespace mvbrdf::calibrate
