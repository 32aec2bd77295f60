// The silhouette term of camera refinement: anchors each camera to the mesh
// (the photometric term alone cannot see a rigid motion of all cameras).
//
// The mesh's occluding contour in a camera: edges between a triangle facing
// the camera and one facing away, kept where they bound the outer silhouette
// (the z-buffer is empty just outside). Each sample point of such an edge is
// paired ICP-style with the intensity edge of the image along the projected
// contour's normal (where the smoothed foreground mask crosses 1/2 within
// +-kSearchPixels, subpixel): the residual is the signed distance, in pixels,
// from the point's projection to the line through that edge point. The
// studio's background is dark (ForegroundMask); an edge without a clear
// crossing is skipped.
#ifndef MVBRDF_CORE_CALIBRATE_SILHOUETTE_TERM_H_
#define MVBRDF_CORE_CALIBRATE_SILHOUETTE_TERM_H_

#include <glm/glm.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "core/calibrate/camera_parameterisation.h"
#include "core/calibrate/depth_map.h"
#include "core/scene/camera_model.h"
#include "core/scene/mesh.h"

namespace mvbrdf::calibrate {

inline constexpr double kSearchPixels = 3.0;

// Mesh edges with the two triangles on them (edges with one or more than two
// are not contour candidates).
struct MeshEdges {
  std::vector<glm::uvec2> vertices;
  std::vector<glm::uvec2> triangles;
};
MeshEdges BuildMeshEdges(const std::vector<glm::uvec3>& triangles);

struct ContourObservation {
  glm::dvec3 point;   // on the mesh, world units
  glm::dvec2 normal;  // outward unit image normal at the calibration pass
  glm::dvec2 target;  // the image edge found along it, pixels
};

// The contour observations of one camera and frame. `mask` is the camera's
// smoothed foreground mask (ForegroundMask), `smoothed` its smoothed grey
// image and `level` the median grey over the mesh: an edge whose inside
// (2 px in) is darker than kMinInsideLevel * level is skipped, since a
// surface in shadow (under the ceiling's lights, the contours facing down)
// fades into the dark background and its edge lies inside the contour
// (0.1 to 0.3 px on the synthetic studio, as a shift upwards).
// Likewise one whose image fades towards the edge (the grey 1 px inside
// below kMinStep of the grey 2.5 px inside).
inline constexpr double kMinInsideLevel = 0.3;
inline constexpr double kMinStep = 0.7;
std::vector<ContourObservation> FindContourObservations(const scene::CameraModel& camera, const MeshEdges& edges,
                                                        const std::vector<glm::uvec3>& triangles,
                                                        const scene::FramePositions& positions, const DepthMap& depth,
                                                        const cv::Mat& mask, const cv::Mat& smoothed, double level);

// Ceres residual: normal . (project(point) - target) - bias, pixels. The
// bias (one for all cameras) is where the detected edge lies outside the
// mesh's contour on average: shading falling off towards the contour and
// the mask's level move it by a fraction of a pixel (0.13 px inwards on the
// synthetic studio at 320x240), which would otherwise pull every camera.
struct SilhouetteResidual {
  const PinholeBase* base;
  ContourObservation obs;
  double inv_scale;
  template <typename T>
  bool operator()(const T* rotation, const T* centre, const T* intrinsics, const T* bias, T* residual) const {
    T uv[2];
    const double x[3] = {obs.point.x, obs.point.y, obs.point.z};
    if (!ProjectWithOffsets(*base, rotation, centre, intrinsics, x, uv)) return false;
    residual[0] = (obs.normal.x * (uv[0] - obs.target.x) + obs.normal.y * (uv[1] - obs.target.y) - bias[0]) * inv_scale;
    return true;
  }
};

// The foreground of a grey image (CV_32F) as a smoothed 0/1 mask: brighter
// than 2 % of the median over `covered` (the mesh's pixels, CV_8U nonzero;
// low, because shading falls off towards the contour and a higher level
// shrinks the silhouette: 0.1 gave a 0.08 px, 0.3 a 0.15 px bias) and than
// three times the 99th percentile of the pixels far from it
// (the background's noise); relative, so the intensity scale does not matter.
cv::Mat ForegroundMask(const cv::Mat& grey, const cv::Mat& covered, double smoothing_pixels);

// Bilinear sample of a CV_32F image (clamped at the border).
double SampleBilinear(const cv::Mat& image, double x, double y);

}  // namespace mvbrdf::calibrate

#endif  // MVBRDF_CORE_CALIBRATE_SILHOUETTE_TERM_H_
