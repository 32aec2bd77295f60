#include "core/calibrate/silhouette_term.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/imgproc.hpp>
#include <utility>

namespace mvbrdf::calibrate {

MeshEdges BuildMeshEdges(const std::vector<glm::uvec3>& triangles) {
  std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> adjacent;
  for (uint32_t t = 0; t < triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      uint32_t a = triangles[t][k], b = triangles[t][(k + 1) % 3];
      if (a > b) std::swap(a, b);
      adjacent[{a, b}].push_back(t);
    }
  }
  MeshEdges edges;
  for (const auto& [e, ts] : adjacent) {
    if (ts.size() != 2) continue;
    edges.vertices.emplace_back(e.first, e.second);
    edges.triangles.emplace_back(ts[0], ts[1]);
  }
  return edges;
}

double SampleBilinear(const cv::Mat& image, double x, double y) {
  x = std::clamp(x, 0.0, static_cast<double>(image.cols - 1));
  y = std::clamp(y, 0.0, static_cast<double>(image.rows - 1));
  const int x0 = std::min(static_cast<int>(x), image.cols - 2), y0 = std::min(static_cast<int>(y), image.rows - 2);
  const double fx = x - x0, fy = y - y0;
  const float* r0 = image.ptr<float>(y0);
  const float* r1 = image.ptr<float>(y0 + 1);
  return (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) + fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
}

cv::Mat ForegroundMask(const cv::Mat& grey, const cv::Mat& covered, double smoothing_pixels) {
  cv::Mat far;
  cv::dilate(covered, far, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(11, 11)));
  std::vector<float> inside, outside;
  for (int y = 0; y < grey.rows; ++y) {
    for (int x = 0; x < grey.cols; ++x) {
      if (covered.at<uint8_t>(y, x)) inside.push_back(grey.at<float>(y, x));
      if (!far.at<uint8_t>(y, x)) outside.push_back(grey.at<float>(y, x));
    }
  }
  double threshold = 0;
  if (!inside.empty()) {
    std::nth_element(inside.begin(), inside.begin() + static_cast<long>(inside.size() / 2), inside.end());
    threshold = 0.02 * inside[inside.size() / 2];
  }
  if (!outside.empty()) {
    const size_t k = std::min(outside.size() - 1, static_cast<size_t>(0.99 * static_cast<double>(outside.size())));
    std::nth_element(outside.begin(), outside.begin() + static_cast<long>(k), outside.end());
    threshold = std::max(threshold, 3.0 * outside[k]);
  }
  cv::Mat mask;
  cv::threshold(grey, mask, threshold, 1.0, cv::THRESH_BINARY);
  cv::Mat smoothed;
  cv::GaussianBlur(mask, smoothed, cv::Size(0, 0), smoothing_pixels);
  return smoothed;
}

namespace {

// Where along `normal` from `p` the smoothed foreground mask crosses 1/2
// going outwards (the crossing nearest p); false when there is none clear.
// The mask (not the intensity) is searched, so the shading falling off
// towards the contour does not pull the edge inwards.
bool FindEdge(const cv::Mat& mask, const glm::dvec2& p, const glm::dvec2& normal, double* offset) {
  constexpr double kStep = 0.25;
  const int n = static_cast<int>(std::lround(kSearchPixels / kStep));
  double best = 1e9;
  for (int i = -n; i < n; ++i) {
    const double s0 = i * kStep, s1 = s0 + kStep;
    const glm::dvec2 a = p + s0 * normal, b = p + s1 * normal;
    const double m0 = SampleBilinear(mask, a.x, a.y) - 0.5, m1 = SampleBilinear(mask, b.x, b.y) - 0.5;
    if (!(m0 >= 0 && m1 < 0)) continue;
    const double s = s0 + kStep * m0 / (m0 - m1);
    if (std::abs(s) < std::abs(best)) best = s;
  }
  if (!(std::abs(best) <= kSearchPixels)) return false;
  const glm::dvec2 in = p + (best - 1.5) * normal, out = p + (best + 1.5) * normal;
  if (!(SampleBilinear(mask, in.x, in.y) > 0.75) || !(SampleBilinear(mask, out.x, out.y) < 0.25)) return false;
  *offset = best;
  return true;
}

}  // namespace

std::vector<ContourObservation> FindContourObservations(const scene::CameraModel& camera, const MeshEdges& edges,
                                                        const std::vector<glm::uvec3>& triangles,
                                                        const scene::FramePositions& positions, const DepthMap& depth,
                                                        const cv::Mat& mask, const cv::Mat& smoothed, double level) {
  std::vector<ContourObservation> out;
  const glm::dvec3 centre = camera.CenterInWorld();
  const auto facing = [&](uint32_t t) {
    const glm::dvec3 a(positions[triangles[t].x]), b(positions[triangles[t].y]), c(positions[triangles[t].z]);
    return glm::dot(glm::cross(b - a, c - a), centre - a) > 0;
  };
  for (size_t e = 0; e < edges.vertices.size(); ++e) {
    const uint32_t t0 = edges.triangles[e].x, t1 = edges.triangles[e].y;
    const bool f0 = facing(t0), f1 = facing(t1);
    if (f0 == f1) continue;
    const uint32_t front = f0 ? t0 : t1;
    const glm::dvec3 a(positions[edges.vertices[e].x]), b(positions[edges.vertices[e].y]);
    uint32_t third = triangles[front].x;
    for (int k = 0; k < 3; ++k) {
      if (triangles[front][k] != edges.vertices[e].x && triangles[front][k] != edges.vertices[e].y) {
        third = triangles[front][k];
      }
    }
    const glm::dvec2 pa = camera.Project(a), pb = camera.Project(b), pc = camera.Project(glm::dvec3(positions[third]));
    const glm::dvec2 along = pb - pa;
    const double length = glm::length(along);
    if (!(length > 1e-6)) continue;
    glm::dvec2 normal(along.y / length, -along.x / length);
    if (glm::dot(normal, pc - 0.5 * (pa + pb)) > 0) normal = -normal;
    // One sample per pixel of edge length, at least one.
    const int samples = std::max(1, static_cast<int>(std::lround(length)));
    for (int s = 0; s < samples; ++s) {
      const double f = (s + 0.5) / samples;
      const glm::dvec3 x = a + f * (b - a);
      const glm::dvec2 p = camera.Project(x);
      const double z = camera.CamFromWorld(x).z;
      if (!(p.x > kSearchPixels + 1 && p.y > kSearchPixels + 1 && p.x < camera.width - kSearchPixels - 2 &&
            p.y < camera.height - kSearchPixels - 2)) {
        continue;
      }
      // The outer silhouette: nothing of the mesh just outside, the point itself seen.
      bool outer = true;
      for (double o : {1.5, 2.5, 3.5}) {
        const glm::dvec2 q = p + o * normal;
        if (depth.Covered(static_cast<int>(std::lround(q.x)), static_cast<int>(std::lround(q.y)))) outer = false;
      }
      if (!outer || !VisibleAt(depth, p - 0.7 * normal, z, 0.02)) continue;
      double offset = 0;
      if (!FindEdge(mask, p, normal, &offset)) continue;
      // A step, not a fade: lit up to the edge (a smoothed step keeps 0.85
      // of its level 1 px inside; a surface darkening towards its contour less).
      const glm::dvec2 in = p + (offset - 2.5) * normal, rim = p + (offset - 1.0) * normal;
      const double inside = SampleBilinear(smoothed, in.x, in.y);
      if (!(inside > kMinInsideLevel * level)) continue;
      if (!(SampleBilinear(smoothed, rim.x, rim.y) > kMinStep * inside)) continue;
      out.push_back({x, normal, p + offset * normal});
    }
  }
  return out;
}

}  // namespace mvbrdf::calibrate
