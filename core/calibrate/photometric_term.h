// Cross-camera photometric consistency (Zhou & Koltun, "Color Map
// Optimization", 2014): surface points seen by two or more cameras should
// have the same colour in each (a diffuse surface; highlights are outliers).
// Camera refinement measures it before and after (the report's
// residual_before/after) and optimises it (PhotometricResidual) beside the
// silhouette term, which fixes the gauge this term cannot see.
#ifndef MVBRDF_CORE_CALIBRATE_PHOTOMETRIC_TERM_H_
#define MVBRDF_CORE_CALIBRATE_PHOTOMETRIC_TERM_H_

#include <ceres/cubic_interpolation.h>

#include <cstdint>
#include <glm/glm.hpp>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "core/calibrate/camera_parameterisation.h"
#include "core/calibrate/depth_map.h"
#include "core/scene/camera_model.h"
#include "core/scene/mesh.h"

namespace mvbrdf::calibrate {

// One frame as camera refinement uses it.
struct RefinementFrame {
  scene::FramePositions positions;
  std::vector<cv::Mat> rgb;       // per camera, CV_32FC3 linear, masked pixels 0
  std::vector<cv::Mat> smoothed;  // per camera, grey CV_32F, Gaussian-smoothed
};

// A surface point and the cameras that see it away from depth edges.
struct SurfacePoint {
  glm::dvec3 point;
  std::vector<int> cameras;
};

// Triangle centroids (every `stride`-th triangle) seen by at least
// `min_cameras` of `cameras`, at least 2 px from any depth discontinuity.
std::vector<SurfacePoint> VisibleSurfacePoints(const std::vector<scene::CameraModel>& cameras,
                                               const std::vector<DepthMap>& depth,
                                               const std::vector<glm::uvec3>& triangles,
                                               const scene::FramePositions& positions, int stride, int min_cameras);

// Textured surface points for the photometric term: from each camera's
// covered pixels (every `stride`-th row and column) with the largest image
// gradients (the top `fraction`, at most `per_camera`), the surface point
// under the pixel, with every camera that sees it away from depth edges
// (at least two).
std::vector<SurfacePoint> TexturedSurfacePoints(const std::vector<scene::CameraModel>& cameras,
                                                const std::vector<DepthMap>& depth,
                                                const std::vector<glm::uvec3>& triangles,
                                                const scene::FramePositions& positions,
                                                const std::vector<cv::Mat>& smoothed, int stride, double fraction,
                                                int per_camera);

// Per camera: rms of (its colour - the mean over the cameras seeing the
// point), linear, over every other triangle centroid of the frames and the
// channels; `observations` gets the point count per camera.
std::vector<double> ConsistencyRms(const std::vector<scene::CameraModel>& cameras,
                                   const std::vector<glm::uvec3>& triangles, const std::vector<RefinementFrame>& frames,
                                   std::vector<uint64_t>* observations);

using ImageGrid = ceres::Grid2D<float, 3>;
using ImageInterpolator = ceres::BiCubicInterpolator<ImageGrid>;

// Ceres residual (3): (colour at the projection - the point's consensus
// colour) / scale; the consensus colour is a parameter block of 3.
struct PhotometricResidual {
  const PinholeBase* base;
  const ImageInterpolator* image;
  glm::dvec3 point;
  double inv_scale;
  template <typename T>
  bool operator()(const T* rotation, const T* centre, const T* intrinsics, const T* colour, T* residual) const {
    T uv[2];
    const double x[3] = {point.x, point.y, point.z};
    if (!ProjectWithOffsets(*base, rotation, centre, intrinsics, x, uv)) return false;
    T c[3];
    image->Evaluate(uv[1], uv[0], c);
    for (int k = 0; k < 3; ++k) residual[k] = (c[k] - colour[k]) * inv_scale;
    return true;
  }
};

}  // namespace mvbrdf::calibrate

#endif  // MVBRDF_CORE_CALIBRATE_PHOTOMETRIC_TERM_H_
