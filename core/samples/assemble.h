// Assembling Samples from one frame's resampling outputs.
//
// Light estimation (§6.1.1) works per triangle: the triangle's mean over its
// valid texels in the camera's averaged atlas, at the triangle's centre c with
// its face normal n in the posed mesh, visibility of light k from the shadow
// atlas over the triangle's texels. Reflectance measurement (§6.2.2) works per
// texel: the resampled value, the texel's posed position and (interpolated)
// normal from the geometry atlas, visibility from its shadow bit.
#ifndef MVBRDF_CORE_SAMPLES_ASSEMBLE_H_
#define MVBRDF_CORE_SAMPLES_ASSEMBLE_H_

#include <vector>

#include <opencv2/core.hpp>

#include "core/atlas/atlas.h"
#include "core/resample/atlas_ops.h"
#include "core/resample/resampler.h"
#include "core/samples/sample_set.h"
#include "core/scene/camera_model.h"
#include "core/scene/light.h"
#include "core/scene/mesh.h"
#include "core/scene/sequence.h"

namespace mvbrdf::samples {

struct AssembleOptions {
  bool inverse_square_falloff = false;
  // A light counts as visible from a triangle when at least this share of the
  // triangle's texels see it in the shadow atlas.
  float min_visible_fraction = 0.5f;
  // Also compute the half-vector geometry of each term for the visitors'
  // LightTerms (n.v, n.h, v.h; null pointers without it): the models other
  // than Phong read it. A SampleSet made with half_vector gets it from
  // AppendTriangleSamples either way.
  bool half_vector_geometry = false;
};

// The shadow atlas of L lights (core/resample/resampler.h ShadowAtlas) is a
// cv::Mat of type CV_16UC(n), n = ShadowChannels(L) = max(1, ceil(L / 16));
// light k is visible where bit k % 16 of channel k / 16 is set. For L <= 16
// that is CV_16UC1.
int ShadowChannels(size_t num_lights);
int ShadowAtlasType(size_t num_lights);
// Whether light k is visible at (row, column) of a shadow atlas.
bool ShadowBit(const cv::Mat& shadows, int row, int column, size_t k);
// Sets that bit (tests, and CPU-made atlases).
void SetShadowBit(cv::Mat* shadows, int row, int column, size_t k);

// The terms of one Sample as the assemblers hand them to visitors: `count`
// lights (ascending) with their g, h and fall-off a (SampleSet's terms;
// g > 0 for each; a = 1 without fall-off), and, when
// AssembleOptions::half_vector_geometry asks, the half-vector geometry: n.v
// of the Sample, n.h and v.h per term (SampleSet::n_dot_v, n_dot_h, v_dot_h;
// else 0 and null).
struct LightTerms {
  size_t count = 0;
  const uint16_t* light = nullptr;
  const float* g = nullptr;
  const float* h = nullptr;
  const float* falloff = nullptr;
  bool any_falloff = false;  // some a != 1
  float n_dot_v = 0.0f;
  const float* n_dot_h = nullptr;
  const float* v_dot_h = nullptr;
  // The half-vector geometry as SampleSet::AddTerms takes it.
  HalfVectorTerms HalfVector() const { return {n_dot_v, n_dot_h, v_dot_h}; }
};

// Per frame t of `sequence`, the lights that are on (bit k =
// sequence.lights[k]): those of the frame's scene.frame_lighting entry, every
// light for a frame without one (the configuration under test selects among
// them later). Requires at most kMaxLights lights.
// The most lights on in any one frame (the most terms a Sample can have).
size_t MaxLightsOn(const std::vector<LightMask>& frame_masks, size_t num_lights);
std::vector<LightMask> FrameLightMasks(const scene::Sequence& sequence);
// Per frame t, 1 when it names its own lights (a scene.frame_lighting entry):
// the frames of LightSelection::own. Empty when no frame or every frame does
// (the configuration is then every light, so nothing is special).
std::vector<uint8_t> OwnLightingFrames(const scene::Sequence& sequence);

// Every light on: the mask of a frame without its own lighting.
LightMask AllLights(size_t num_lights);

// Clears in a shadow atlas (CV_16UC(ShadowChannels), see above) the bits of the
// lights that are off in its frame, so that every Sample assembled from it
// (triangle, texel and pixel Samples) has g = h = 0 for them: a light that is
// off lights nothing. A no-op when `on` covers every light of the atlas.
void ApplyLightMask(const LightMask& on, size_t num_lights, cv::Mat* shadows);

// An empty set for `lights` (names and intensities filled in); with
// `half_vector` it stores the half-vector geometry of every Sample appended
// (SampleSet::half_vector; the models other than the thesis's Phong).
SampleSet MakeSampleSet(const std::vector<scene::Light>& lights, bool half_vector = false);

// Appends one sample per valid triangle of `means` (AverageTriangles of camera
// `camera`'s resampled atlas in frame `frame`). `file_positions` is the posed
// mesh of the frame; `shadows` the frame's ShadowAtlas (bit k = light k).
// Triangles with zero area are skipped.
void AppendTriangleSamples(const std::vector<resample::TriangleMean>& means, const atlas::Atlas& atlas,
                           const scene::FramePositions& file_positions, const cv::Mat& shadows,
                           const scene::CameraModel& camera, int camera_index, int frame,
                           const std::vector<scene::Light>& lights, const AssembleOptions& options, SampleSet* out);

// Per-texel cosines of one (frame, camera) without storing samples: calls
// `visit(texel, rgb, const LightTerms& terms)` for every valid texel of
// `resampled` (the terms are valid during the call) in atlas rows [rows.begin,
// rows.end) (end < 0: to the last), in row-major order. The reflectance
// passes stream through this instead of materialising every texel sample;
// disjoint row ranges may be visited on threads of their own.
struct TexelRows {
  int begin = 0;
  int end = -1;
};
template <typename Visit>
void ForEachTexelSample(const cv::Mat& resampled, const resample::GeometryAtlas& geometry, const cv::Mat& shadows,
                        const scene::CameraModel& camera, const std::vector<scene::Light>& lights,
                        const AssembleOptions& options, Visit&& visit, TexelRows rows = {});

// The same texels as ForEachTexelSample, with the surface instead of the
// terms: visit(texel, rgb, point, unit_normal, bits), `bits` the texel's
// shadow-atlas channels (ShadowChannels(lights.size()) values), for callers
// that read the lights at other normals (issue #18: PointTerms below).
template <typename Visit>
void ForEachTexelObservation(const cv::Mat& resampled, const resample::GeometryAtlas& geometry, const cv::Mat& shadows,
                             const scene::CameraModel& camera, size_t num_lights, Visit&& visit, TexelRows rows = {});

// Per-pixel Samples of one (frame, camera): every video pixel whose centre
// shows the mesh (with its four neighbours, so silhouettes are left out) and
// faces the camera by more than `min_cos_view`, with the exact surface point
// and normal under it (Resampler::Surface) and its atlas texel; calls
// visit(texel, rgb, const LightTerms& terms). Unlike texel Samples these
// carry no resampling blur, which matters for highlights (ks, ke).
//
// `footprint` > 1 models what a sensor pixel records, the mean over its area:
// the pixel's terms are those of footprint x footprint subpixels (the surface
// under each interpolated from the maps, assemble_internal::SurfaceBetween),
// subpixel s of light k as light k * footprint^2 + s of FootprintLights(lights,
// footprint), its g and a divided by footprint^2 (so a model's sum over the
// terms is the mean of its value over the subpixels); n.v is their mean. The
// visitor's set must then be made with FootprintLights and its selection
// widened by FootprintSelection. 1: the pixel centre, the lights as they are.
inline constexpr int kMaxPixelFootprint = 4;
template <typename Visit>
void ForEachPixelSample(const cv::Mat& frame, const resample::CameraSurface& surface, const cv::Mat& shadows,
                        const scene::CameraModel& camera, const std::vector<scene::Light>& lights,
                        const AssembleOptions& options, double min_cos_view, Visit&& visit, int footprint = 1);

// `lights`, each listed footprint^2 times in a row (light k's copies are k *
// footprint^2 + s), for the Samples of ForEachPixelSample with `footprint`.
std::vector<scene::Light> FootprintLights(const std::vector<scene::Light>& lights, int footprint);
// A selection of the original lights as the same selection of their copies.
LightSelection FootprintSelection(const LightSelection& selection, int footprint);

}  // namespace mvbrdf::samples

#include "core/samples/assemble_inl.h"

#endif  // MVBRDF_CORE_SAMPLES_ASSEMBLE_H_
