#include "core/calibrate/photometric_term.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/calibrate/silhouette_term.h"

namespace mvbrdf::calibrate {

namespace {

// The cameras that see x away from depth edges.
std::vector<int> SeenBy(const std::vector<scene::CameraModel>& cameras, const std::vector<DepthMap>& depth,
                        const glm::dvec3& x) {
  std::vector<int> seen;
  for (size_t c = 0; c < cameras.size(); ++c) {
    const glm::dvec2 uv = cameras[c].Project(x);
    const double z = cameras[c].CamFromWorld(x).z;
    if (!VisibleAt(depth[c], uv, z, 0.01)) continue;
    const int px = static_cast<int>(std::lround(uv.x)), py = static_cast<int>(std::lround(uv.y));
    bool smooth = true;
    for (int dy = -2; dy <= 2 && smooth; ++dy) {
      for (int dx = -2; dx <= 2 && smooth; ++dx) {
        if (!depth[c].Covered(px + dx, py + dy) || std::abs(depth[c].At(px + dx, py + dy) - z) > 0.03 * z) {
          smooth = false;
        }
      }
    }
    if (smooth) seen.push_back(static_cast<int>(c));
  }
  return seen;
}

}  // namespace

std::vector<SurfacePoint> TexturedSurfacePoints(const std::vector<scene::CameraModel>& cameras,
                                                const std::vector<DepthMap>& depth,
                                                const std::vector<glm::uvec3>& triangles,
                                                const scene::FramePositions& positions,
                                                const std::vector<cv::Mat>& smoothed, int stride, double fraction,
                                                int per_camera) {
  std::vector<SurfacePoint> out;
  for (size_t c = 0; c < cameras.size(); ++c) {
    const scene::CameraModel& camera = cameras[c];
    const DepthMap& map = depth[c];
    std::vector<std::pair<double, glm::ivec2>> candidates;
    for (int y = 2; y < map.height - 2; y += stride) {
      for (int x = 2; x < map.width - 2; x += stride) {
        if (!map.Covered(x, y)) continue;
        // Away from depth edges (where the steepest gradients are the silhouette's).
        bool smooth = true;
        for (int dy = -3; dy <= 3 && smooth; ++dy) {
          for (int dx = -3; dx <= 3 && smooth; ++dx) {
            if (!map.Covered(x + dx, y + dy) || std::abs(map.At(x + dx, y + dy) - map.At(x, y)) > 0.03 * map.At(x, y)) {
              smooth = false;
            }
          }
        }
        if (!smooth) continue;
        const cv::Mat& s = smoothed[c];
        const double gx = s.at<float>(y, x + 1) - s.at<float>(y, x - 1);
        const double gy = s.at<float>(y + 1, x) - s.at<float>(y - 1, x);
        candidates.emplace_back(gx * gx + gy * gy, glm::ivec2(x, y));
      }
    }
    if (candidates.empty()) continue;
    const size_t keep = std::min(static_cast<size_t>(per_camera),
                                 static_cast<size_t>(fraction * static_cast<double>(candidates.size())));
    if (keep == 0) continue;
    std::nth_element(candidates.begin(), candidates.begin() + static_cast<long>(keep - 1), candidates.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    const glm::dvec3 centre = camera.CenterInWorld();
    const glm::dmat3 world_from_cam = glm::transpose(camera.cam_from_world_rotation);
    for (size_t i = 0; i < keep; ++i) {
      const glm::ivec2 p = candidates[i].second;
      const glm::uvec3 tri = triangles[static_cast<size_t>(map.TriangleAt(p.x, p.y))];
      const glm::dvec3 a(positions[tri.x]), b(positions[tri.y]), cc(positions[tri.z]);
      const glm::dvec2 n = camera.Undistort(glm::dvec2((p.x - camera.cx) / camera.fx, (p.y - camera.cy) / camera.fy));
      const glm::dvec3 dir = world_from_cam * glm::dvec3(n, 1.0);
      const glm::dvec3 normal = glm::cross(b - a, cc - a);
      const double denom = glm::dot(normal, dir);
      if (!(std::abs(denom) > 0)) continue;
      const glm::dvec3 x = centre + (glm::dot(normal, a - centre) / denom) * dir;
      SurfacePoint sp{x, SeenBy(cameras, depth, x)};
      if (sp.cameras.size() >= 2) out.push_back(std::move(sp));
    }
  }
  return out;
}

std::vector<SurfacePoint> VisibleSurfacePoints(const std::vector<scene::CameraModel>& cameras,
                                               const std::vector<DepthMap>& depth,
                                               const std::vector<glm::uvec3>& triangles,
                                               const scene::FramePositions& positions, int stride, int min_cameras) {
  std::vector<SurfacePoint> out;
  for (size_t t = 0; t < triangles.size(); t += static_cast<size_t>(stride)) {
    const glm::dvec3 x = (glm::dvec3(positions[triangles[t].x]) + glm::dvec3(positions[triangles[t].y]) +
                          glm::dvec3(positions[triangles[t].z])) /
                         3.0;
    SurfacePoint sp{x, SeenBy(cameras, depth, x)};
    if (static_cast<int>(sp.cameras.size()) >= min_cameras) out.push_back(std::move(sp));
  }
  return out;
}

std::vector<double> ConsistencyRms(const std::vector<scene::CameraModel>& cameras,
                                   const std::vector<glm::uvec3>& triangles, const std::vector<RefinementFrame>& frames,
                                   std::vector<uint64_t>* observations) {
  std::vector<double> sum(cameras.size(), 0.0);
  observations->assign(cameras.size(), 0);
  for (const RefinementFrame& frame : frames) {
    std::vector<DepthMap> depth;
    for (const auto& camera : cameras) depth.push_back(RenderDepth(camera, triangles, frame.positions));
    for (const SurfacePoint& sp : VisibleSurfacePoints(cameras, depth, triangles, frame.positions, 2, 2)) {
      std::vector<glm::dvec3> colour;
      glm::dvec3 mean(0.0);
      for (int c : sp.cameras) {
        const glm::dvec2 uv = cameras[static_cast<size_t>(c)].Project(sp.point);
        const cv::Mat& rgb = frame.rgb[static_cast<size_t>(c)];
        glm::dvec3 v;
        const double x = uv.x, y = uv.y;
        const int x0 = std::min(static_cast<int>(x), rgb.cols - 2), y0 = std::min(static_cast<int>(y), rgb.rows - 2);
        const double fx = x - x0, fy = y - y0;
        for (int k = 0; k < 3; ++k) {
          v[k] = (1 - fy) * ((1 - fx) * rgb.at<cv::Vec3f>(y0, x0)[k] + fx * rgb.at<cv::Vec3f>(y0, x0 + 1)[k]) +
                 fy * ((1 - fx) * rgb.at<cv::Vec3f>(y0 + 1, x0)[k] + fx * rgb.at<cv::Vec3f>(y0 + 1, x0 + 1)[k]);
        }
        colour.push_back(v);
        mean += v;
      }
      mean /= static_cast<double>(colour.size());
      for (size_t i = 0; i < sp.cameras.size(); ++i) {
        const glm::dvec3 d = colour[i] - mean;
        sum[static_cast<size_t>(sp.cameras[i])] += glm::dot(d, d) / 3.0;
        (*observations)[static_cast<size_t>(sp.cameras[i])] += 1;
      }
    }
  }
  std::vector<double> rms(cameras.size(), 0.0);
  for (size_t c = 0; c < cameras.size(); ++c) {
    if ((*observations)[c] > 0) rms[c] = std::sqrt(sum[c] / static_cast<double>((*observations)[c]));
  }
  return rms;
}

}  // namespace mvbrdf::calibrate
