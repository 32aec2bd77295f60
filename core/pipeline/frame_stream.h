// One pass over a sequence's frames on the GPU: per frame the pose, the
// geometry and shadow atlases (SetFrame), then each camera's video frame
// resampled into the atlas (Resample) and the surface under its pixels
// (Surface). The reconstruction's passes and the service's gather task read
// frames through it.
#ifndef MVBRDF_CORE_PIPELINE_FRAME_STREAM_H_
#define MVBRDF_CORE_PIPELINE_FRAME_STREAM_H_

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/atlas/atlas.h"
#include "core/atlas/texel_tangents.h"
#include "core/gl/egl_context.h"
#include "core/pipeline/resampled_atlas_cache.h"
#include "core/pipeline/shadow_atlas_cache.h"
#include "core/resample/resampler.h"
#include "core/samples/assemble.h"
#include "core/scene/sequence.h"
#include "core/scene/video_source.h"

namespace mvbrdf::pipeline {

class FrameStream {
 public:
  // The resampler and every camera's video. With `shadows`, SetFrame takes
  // a frame's shadow atlas from it when an earlier pass kept it there, and
  // keeps the ones it computes; with `atlases`, Resample keeps each atlas it
  // computes there and ResampledAtlas reads it back (the caller's; they
  // outlive the stream).
  static absl::StatusOr<std::unique_ptr<FrameStream>> Open(const scene::Sequence& sequence, gl::EglContext& context,
                                                           const atlas::Atlas& atlas,
                                                           const resample::ResamplerOptions& options,
                                                           ShadowAtlasCache* shadows = nullptr,
                                                           ResampledAtlasCache* atlases = nullptr);

  // Loads frame t: pose, geometry and shadow atlases. The shadow atlas holds
  // only the lights on in frame t (scene.frame_lighting,
  // samples::ApplyLightMask): every Sample assembled from it knows them.
  absl::Status SetFrame(int t);

  // Reads camera `camera`'s video frame (kept as last_frame(), with the
  // resampler's unreliable pixels marked: Resampler::MarkUnreliable) and
  // resamples it.
  absl::StatusOr<cv::Mat> Resample(int camera);
  // The same atlas, from the atlas cache when an earlier pass kept it there
  // (then without reading the video: last_frame() is not this frame's), else
  // Resample(camera).
  absl::StatusOr<cv::Mat> ResampledAtlas(int camera);
  // Only the video frame, as Resample reads it (last_frame()), for passes
  // that take per-pixel Samples and no atlas.
  absl::Status ReadFrame(int camera);
  // The surface under the camera's pixels (with UseNormals: the refined
  // normals where the pixel's texel has one).
  absl::StatusOr<resample::CameraSurface> Surface(int camera);
  // Texel observations refused as masked or saturated so far
  // (Resampler::Refused), the atlases read from the cache included.
  resample::Resampler::RefusedObservations Refused(int camera) const;
  const cv::Mat& last_frame() const { return last_frame_; }

  // Issue #18: from the next SetFrame on, the geometry atlas's normals are
  // the refined ones where `refined[texel]` is 1: the tangent-space
  // `tangent_normals[texel]` read in the frame's tangent frames
  // (atlas::TexelTangents), so every Sample assembled from geometry() or
  // Surface() sees them. Both vectors are the caller's and outlive the stream.
  void UseNormals(const std::vector<glm::vec3>* tangent_normals, const std::vector<uint8_t>* refined);

  const scene::FramePositions& positions() const { return positions_; }
  const cv::Mat& shadows() const { return shadows_; }
  const resample::GeometryAtlas& geometry() const { return geometry_; }

 private:
  explicit FrameStream(const scene::Sequence& sequence) : sequence_(sequence) {}
  const scene::Sequence& sequence_;
  std::unique_ptr<resample::Resampler> resampler_;
  std::vector<std::unique_ptr<scene::VideoSource>> videos_;
  scene::FramePositions positions_;
  cv::Mat shadows_;
  resample::GeometryAtlas geometry_;
  cv::Mat last_frame_;
  std::vector<samples::LightMask> frame_lights_;  // per frame (samples::FrameLightMasks)
  ShadowAtlasCache* shadow_cache_ = nullptr;
  ResampledAtlasCache* atlas_cache_ = nullptr;
  std::vector<std::string> atlas_keys_;  // per camera: what its atlases depend on besides the frame
  std::vector<resample::Resampler::RefusedObservations> cached_refused_;  // per camera, of atlases read back
  const atlas::Atlas* atlas_ = nullptr;
  std::unique_ptr<atlas::TexelTangents> tangents_;  // with UseNormals
  const std::vector<glm::vec3>* tangent_normals_ = nullptr;
  const std::vector<uint8_t>* refined_ = nullptr;
  std::vector<glm::vec4> frame_tangents_;  // per texel, this frame's (with UseNormals)
  std::string shadow_key_;  // the lights, as ShadowAtlasCache keys them
  int frame_ = 0;
};

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_FRAME_STREAM_H_
