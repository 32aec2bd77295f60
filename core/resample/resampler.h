// Resampling on the GPU (thesis chapter 5, §6.1.1): every video frame of every
// camera into the one texture atlas of the mesh, with visibility by shadow
// mapping from the camera, plus per-frame geometry and light-visibility
// (shadow) atlases.
//
// Per frame: SetFrame() renders the posed position and normal of every texel
// once (the mesh drawn in atlas space). Each camera's depth map is rendered by
// the first ResampleCamera() of that camera in the frame (so cameras a caller
// skips cost nothing), the per-light shadow maps by the first ShadowAtlas().
// Each camera is resampled by a full-screen pass over the atlas that reads
// the position map, projects the point with the camera's intrinsics and
// distortion, tests facing and depth and samples the frame (see
// ../shared/PERF.md for why: ~3x faster than drawing the mesh per camera).
//
// Visibility from a camera: its depth map is an undistorted pinhole with the
// camera's focal lengths, widened (principal point shifted) to hold the
// pinhole projection of every point whose distorted pixel lies in the image;
// it stores inverse eye depth 1 / z (z camera-space, world units; R32F, 0 where
// no surface), looked up bilinearly at the point's pinhole projection. 1 / z
// is affine in the image over a triangle, so the lookup is exact on the
// point's own triangle and slanted surfaces do not occlude themselves however
// grazing the view. A texel is occluded when z > (1 + relative_depth_tolerance)
// times the looked-up depth plus absolute_depth_tolerance. The frame is sampled bilinearly at the
// distorted pixel (CameraModel::Project). Occlusion boundaries are placed to
// within about one camera pixel (the depth map has the camera's resolution).
//
// Triangles listed in topology.zero_area_triangles are neither resampled nor
// cast shadows (core/scene/mesh.h).
//
// All atlas images follow the convention of core/atlas/atlas.h (row 0 at
// the top, v = 1). Threading: all calls on the thread where the context is
// current; the context must outlive the resampler. Calls change the
// context's bindings (framebuffer, program, textures, vertex array) and leave
// none of the resampler's objects bound.
#ifndef MVBRDF_CORE_RESAMPLE_RESAMPLER_H_
#define MVBRDF_CORE_RESAMPLE_RESAMPLER_H_

#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/statusor.h"
#include "core/atlas/atlas.h"
#include "core/gl/egl_context.h"
#include "core/scene/camera_model.h"
#include "core/scene/light.h"
#include "core/scene/mesh.h"

namespace mvbrdf::resample {

struct ResamplerOptions {
  // Texels whose normal is within this angle of perpendicular to the view
  // direction are invalid (grazing views smear the image); 0 keeps every
  // front-facing texel. Valid iff dot(n, v) > sin(margin). In [0, 90).
  double grazing_margin_deg = 5.0;
  // Depth test against the camera's depth map: a texel is occluded when it
  // lies further than this (relative to its depth) behind the map. >= 0.
  // The bilinear depth map lies in front of a coarse mesh's concave creases,
  // so a tight tolerance refuses texels there.
  double relative_depth_tolerance = 0.001;
  // And this much in world units (>= 0): occluded when z > (1 + relative) *
  // z_map + absolute. A job sets one of the two (FittingOptions).
  double absolute_depth_tolerance = 0.0;
  // Within the tolerance, the exact test: a texel is also occluded when one
  // of the triangles the camera sees at the four depth-map pixels around its
  // projection (other than the texel's own) crosses the ray from the texel
  // to the camera, more than 1e-4 of the depth in front of it. A texel just
  // inside another part of the mesh (parts interpenetrate: a tracked arm in
  // the torso, a body's overlapping ellipsoids) lies behind that part by less
  // than the tolerance and would take its colour; a crease's neighbouring
  // triangle, which the ray does not cross, does not occlude. false = the
  // depth map alone (resampler_test's
  // DepthToleranceSetsTheBandOfTexelsInsideAnotherPartThatPass measures both).
  bool exact_occluder_test = true;
  // Resolution of the per-light cube depth maps (texels per face; also the
  // side of a directional light's orthographic map). In [1, 8192]; GPU memory
  // is 24 * size^2 bytes per point light (24 MB at 1024).
  int shadow_map_size = 1024;
  // Sample reliability (issue #14, MarkUnreliable): camera pixels within this
  // many pixels of a silhouette or a depth discontinuity of the camera's
  // depth map are marked kEdgePixel; 0: none. >= 0.
  double edge_margin_pixels = 0.0;
  // Pixels where the image's relative gradient |grad Y| * 1 px / mean Y (Y =
  // mean of the channels, central differences, 3x3 mean; unit-free) exceeds
  // this are marked kGradientPixel; 0: none. >= 0.
  double gradient_rejection = 0.0;
  // Surface(): the triangle maps (CameraSurface::triangle, triangles) for
  // every pinhole camera, not only distorted ones: per-pixel Samples of a
  // pixel's footprint read each subpixel's ray off its own triangle.
  bool surface_triangles = false;
};

// Marks of unreliable pixels (negative, like scene::kMaskedPixel): a texel
// whose footprint touches one is refused, a pixel Sample is never built.
inline constexpr float kEdgePixel = -3.0f;
inline constexpr float kGradientPixel = -4.0f;
// A depth discontinuity of the depth map: inverse depth d (affine in the
// image over a plane) whose second difference along a row or column exceeds
// this fraction of d (MarkUnreliable).
inline constexpr double kDepthDiscontinuity = 0.02;

// One frame's surface in atlas space.
struct GeometryAtlas {
  cv::Mat position;  // CV_32FC4: posed world position (xyz), w = 1 where covered, 0 elsewhere
  cv::Mat normal;    // CV_32FC4: unit normal (interpolated vertex normals), w as above
};

// The surface under every pixel centre of a camera in the current frame, from
// the camera's pinhole depth pass (no distortion: look a distorted pixel up
// at its undistorted position). Pixel (x, y) of these maps is the pinhole
// pixel (x, y) of a camera with the same focal lengths and principal point
// (cx, cy); without distortion that is the camera's own grid.
//
// A distorted pixel's ray, or a subpixel's, meets the map between its
// centres. For distorted cameras (and every pinhole one with
// ResamplerOptions::surface_triangles) the maps carry the drawn triangle
// under each centre and the frame's triangles, so that the surface on such a
// ray can be found exactly (samples::assemble_internal::SurfaceOnRay) rather
// than interpolated between centres.
struct SurfaceTriangle {
  glm::vec3 position[3];  // posed world corners
  glm::vec3 normal[3];    // the vertex normals the depth pass interpolates
};
struct CameraSurface {
  cv::Mat position_texel;  // CV_32FC4: world xyz; w = atlas texel index + 1 (0: no surface)
  cv::Mat normal;          // CV_32FC4: unit interpolated normal
  double cx = 0.0, cy = 0.0;
  // Distorted cameras, and pinhole ones with ResamplerOptions::
  // surface_triangles (else empty / null): CV_32SC1, the drawn triangle under
  // the pixel centre (-1: none), indexing `triangles`.
  cv::Mat triangle;
  std::shared_ptr<const std::vector<SurfaceTriangle>> triangles;
};

class Resampler {
 public:
  // `atlas` fixes the layout (its topology's render vertices and UVs);
  // `cameras` and `lights` are the scene's (all candidate lights, any number).
  static absl::StatusOr<std::unique_ptr<Resampler>> Create(gl::EglContext& context, const atlas::Atlas& atlas,
                                                           const std::vector<scene::CameraModel>& cameras,
                                                           const std::vector<scene::Light>& lights,
                                                           const ResamplerOptions& options);
  ~Resampler();
  Resampler(const Resampler&) = delete;
  Resampler& operator=(const Resampler&) = delete;

  // Starts a frame: file-vertex positions of the pose (normals are computed
  // here, area-weighted per file vertex).
  absl::Status SetFrame(const scene::FramePositions& file_positions);

  // Camera `camera`'s frame (CV_32FC3 linear RGB at the camera's size, row 0
  // top) resampled into the atlas: CV_32FC4, rgb = radiance, a = 1 where
  // valid, a = 0 where not (uncovered, back-facing or grazing, outside the
  // image, or occluded), so that invalid is distinguishable from black.
  // Pixels of `frame` marked invalid (scene::kMaskedPixel, kSaturatedPixel:
  // outside the mask, saturated) invalidate every texel whose footprint
  // touches one; such texels are counted in Refused(camera).
  absl::StatusOr<cv::Mat> ResampleCamera(int camera, const cv::Mat& frame);

  // Issue #14 (sample reliability): marks, in `frame` (camera `camera`'s
  // CV_32FC3 image of the current frame), the pixels near the camera's
  // silhouettes and depth discontinuities (kEdgePixel, options'
  // edge_margin_pixels) and on steep gradients (kGradientPixel,
  // gradient_rejection), keeping existing marks. Call before
  // ResampleCamera with the same frame, so texel and pixel Samples alike
  // skip them. No-op when both options are 0.
  absl::Status MarkUnreliable(int camera, cv::Mat* frame);

  // Texel observations of `camera` refused so far (over every ResampleCamera
  // call) because their footprint touched a masked or a saturated pixel
  // (otherwise they were valid).
  struct RefusedObservations {
    uint64_t masked = 0;
    uint64_t saturated = 0;
    uint64_t edge = 0;      // footprint touched a kEdgePixel (MarkUnreliable)
    uint64_t gradient = 0;  // footprint touched a kGradientPixel
    uint64_t kept = 0;      // valid texels returned
  };
  RefusedObservations Refused(int camera) const;

  // The current frame's geometry atlas (read back from the GPU on each call).
  absl::StatusOr<GeometryAtlas> Geometry();

  // Camera `camera`'s surface map of the current frame: exact per-pixel
  // Samples (the video's pixel and the surface point it shows), free of the
  // atlas's bilinear blur, for fitting highlights.
  absl::StatusOr<CameraSurface> Surface(int camera);

  // CV_16UC(n), n = max(1, ceil(lights / 16)): bit k % 16 of channel k / 16
  // set where light k is visible from the texel's surface point (shadow test
  // only; the cosine is computed by later stages); 0 at uncovered texels.
  // `lights_needed` (empty: every light; else one entry per light) says which
  // lights the frame needs: bits of the others are 0 and cost nothing (an
  // OLAT frame computes one shadow map). Lights are drawn in passes of up to
  // 16, one per channel with a needed light, the shadow maps of a pass's
  // lights only (GPU memory for at most 16 lights). Computed once per frame
  // and set of lights (later calls return a copy). Shadow maps as
  // core/render's renderer (cube maps of the distance for point lights, an
  // orthographic map for directional lights, slope-scaled bias from the
  // interpolated normal).
  absl::StatusOr<cv::Mat> ShadowAtlas(const std::vector<bool>& lights_needed = {});

 private:
  struct Impl;
  explicit Resampler(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mvbrdf::resample

#endif  // MVBRDF_CORE_RESAMPLE_RESAMPLER_H_
