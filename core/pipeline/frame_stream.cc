#include "core/pipeline/frame_stream.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/scene/tangent_frames.h"

namespace mvbrdf::pipeline {
namespace {

// The lights on in frame t, one entry per light, for the resampler's shadow
// passes (an OLAT frame computes one shadow map); empty: every light.
std::vector<bool> LightsOnIn(const scene::Sequence& sequence, int t) {
  const v1::FrameLighting* fl = sequence.FrameLightingOf(t);
  if (fl == nullptr) return {};
  std::vector<bool> on(sequence.lights.size(), false);
  for (const std::string& name : fl->lights()) {
    const int k = sequence.FindLight(name);
    if (k >= 0) on[static_cast<size_t>(k)] = true;  // validation refuses unknown names
  }
  return on;
}

// What camera c's resampled atlases depend on besides the frame (the mesh,
// video and atlas layout are the job's): the camera as calibrated and the
// resampler's options, every double bit for bit.
std::string AtlasKey(const scene::CameraModel& m, int atlas_size, const resample::ResamplerOptions& o) {
  std::string key = absl::StrFormat("%s %d %dx%d %a %a %a %a %a %d", m.name, atlas_size, m.width, m.height, m.fx,
                                    m.fy, m.cx, m.cy, m.pixel_size, m.orthographic() ? 1 : 0);
  for (double k : m.distortion) absl::StrAppend(&key, absl::StrFormat(" %a", k));
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) absl::StrAppend(&key, absl::StrFormat(" %a", m.cam_from_world_rotation[i][j]));
    absl::StrAppend(&key, absl::StrFormat(" %a", m.cam_from_world_translation[i]));
  }
  absl::StrAppend(&key, absl::StrFormat(" | %a %a %a %d %a %a", o.grazing_margin_deg, o.relative_depth_tolerance,
                                        o.absolute_depth_tolerance, o.exact_occluder_test ? 1 : 0,
                                        o.edge_margin_pixels, o.gradient_rejection));
  return key;
}

void AddRefused(const resample::Resampler::RefusedObservations& a, resample::Resampler::RefusedObservations* sum) {
  sum->masked += a.masked;
  sum->saturated += a.saturated;
  sum->edge += a.edge;
  sum->gradient += a.gradient;
  sum->kept += a.kept;
}

}  // namespace

absl::StatusOr<std::unique_ptr<FrameStream>> FrameStream::Open(const scene::Sequence& sequence,
                                                               gl::EglContext& context, const atlas::Atlas& atlas,
                                                               const resample::ResamplerOptions& options,
                                                               ShadowAtlasCache* shadows,
                                                               ResampledAtlasCache* atlases) {
  auto s = std::unique_ptr<FrameStream>(new FrameStream(sequence));
  s->shadow_cache_ = shadows;
  s->atlas_cache_ = atlases;
  for (const scene::CameraModel& camera : sequence.cameras) {
    s->atlas_keys_.push_back(AtlasKey(camera, atlas.size, options));
  }
  s->cached_refused_.resize(sequence.cameras.size());
  s->atlas_ = &atlas;
  // What a frame's shadow atlas depends on besides the frame: the lights
  // (positions, directions) and the resampler's atlas and shadow maps.
  s->shadow_key_ = absl::StrCat(atlas.size, " ", options.shadow_map_size);
  for (const scene::Light& l : sequence.lights) {
    const glm::vec3& p = l.directional ? l.direction : l.position;
    absl::StrAppend(&s->shadow_key_, l.directional ? " d" : " p", absl::StrFormat(" %a %a %a", p.x, p.y, p.z));
  }
  s->frame_lights_ = samples::FrameLightMasks(sequence);
  MVBRDF_ASSIGN_OR_RETURN(s->resampler_,
                          resample::Resampler::Create(context, atlas, sequence.cameras, sequence.lights, options));
  for (int c = 0; c < static_cast<int>(sequence.cameras.size()); ++c) {
    MVBRDF_ASSIGN_OR_RETURN(auto video, scene::VideoSource::Open(sequence.scene.cameras(c), sequence.scene_dir,
                                                                 sequence.frames, sequence.num_frames,
                                                                 absl::StrCat("scene.cameras[", c, "]")));
    s->videos_.push_back(std::move(video));
  }
  return s;
}

absl::Status FrameStream::SetFrame(int t) {
  if (t < 0 || static_cast<size_t>(t) >= frame_lights_.size()) {
    return absl::OutOfRangeError(absl::StrCat("frame ", t, " outside [0, ", frame_lights_.size(), ")"));
  }
  MVBRDF_ASSIGN_OR_RETURN(positions_, sequence_.LoadFrame(t));
  MVBRDF_RETURN_IF_ERROR(resampler_->SetFrame(positions_));
  std::optional<cv::Mat> kept;
  if (shadow_cache_ != nullptr) kept = shadow_cache_->Find(t, shadow_key_);
  if (kept.has_value()) {
    shadows_ = *std::move(kept);
  } else {
    MVBRDF_ASSIGN_OR_RETURN(shadows_, resampler_->ShadowAtlas(LightsOnIn(sequence_, t)));
    samples::ApplyLightMask(frame_lights_[static_cast<size_t>(t)], sequence_.lights.size(), &shadows_);
    if (shadow_cache_ != nullptr) shadow_cache_->Keep(t, shadow_key_, shadows_);
  }
  MVBRDF_ASSIGN_OR_RETURN(geometry_, resampler_->Geometry());
  if (tangent_normals_ != nullptr) {
    frame_tangents_ = tangents_->Compute(positions_);
    const std::vector<glm::vec4>& tangents = frame_tangents_;
    cv::Mat normal = geometry_.normal.clone();
    for (int row = 0; row < normal.rows; ++row) {
      cv::Vec4f* n = normal.ptr<cv::Vec4f>(row);
      for (int column = 0; column < normal.cols; ++column) {
        const size_t i = static_cast<size_t>(row) * static_cast<size_t>(normal.cols) + static_cast<size_t>(column);
        if ((*refined_)[i] == 0 || !(n[column][3] > 0.5f)) continue;
        const glm::vec3 mesh(n[column][0], n[column][1], n[column][2]);
        const float length = glm::length(mesh);
        if (!(length > 0.0f)) continue;
        const glm::vec3 refined =
            glm::normalize(scene::FrameAt(tangents[i], mesh / length).ToWorld((*tangent_normals_)[i]));
        n[column] = {refined.x, refined.y, refined.z, n[column][3]};
      }
    }
    geometry_.normal = normal;
  }
  frame_ = t;
  return absl::OkStatus();
}

void FrameStream::UseNormals(const std::vector<glm::vec3>* tangent_normals, const std::vector<uint8_t>* refined) {
  tangent_normals_ = tangent_normals;
  refined_ = refined;
  tangents_ = tangent_normals != nullptr ? std::make_unique<atlas::TexelTangents>(*atlas_) : nullptr;
}

absl::StatusOr<resample::CameraSurface> FrameStream::Surface(int camera) {
  MVBRDF_ASSIGN_OR_RETURN(resample::CameraSurface surface, resampler_->Surface(camera));
  // Until SetFrame has computed this frame's tangents, the mesh's normals.
  if (tangent_normals_ == nullptr || frame_tangents_.size() != refined_->size()) return surface;
  // The refined normals live in the maps: a distorted pixel's surface is
  // interpolated between them (SurfaceBetween), not read off its triangle's
  // vertex normals.
  surface.triangle.release();
  surface.triangles.reset();
  cv::Mat normal = surface.normal.clone();
  const size_t texels = refined_->size();
  for (int y = 0; y < normal.rows; ++y) {
    const cv::Vec4f* p = surface.position_texel.ptr<cv::Vec4f>(y);
    cv::Vec4f* n = normal.ptr<cv::Vec4f>(y);
    for (int x = 0; x < normal.cols; ++x) {
      const int64_t texel = static_cast<int64_t>(p[x][3]) - 1;  // w = texel + 1, 0: no surface
      if (texel < 0 || static_cast<size_t>(texel) >= texels || (*refined_)[static_cast<size_t>(texel)] == 0) continue;
      const glm::vec3 mesh(n[x][0], n[x][1], n[x][2]);
      const float length = glm::length(mesh);
      if (!(length > 0.0f)) continue;
      const glm::vec3 refined = glm::normalize(scene::FrameAt(frame_tangents_[static_cast<size_t>(texel)], mesh / length)
                                                   .ToWorld((*tangent_normals_)[static_cast<size_t>(texel)]));
      n[x] = {refined.x, refined.y, refined.z, n[x][3]};
    }
  }
  surface.normal = normal;
  return surface;
}

absl::Status FrameStream::ReadFrame(int camera) {
  if (camera < 0 || static_cast<size_t>(camera) >= videos_.size()) {
    return absl::OutOfRangeError(absl::StrCat("camera ", camera, " outside [0, ", videos_.size(), ")"));
  }
  MVBRDF_ASSIGN_OR_RETURN(last_frame_, videos_[static_cast<size_t>(camera)]->ReadFrame(frame_));
  // Unreliable pixels marked (issue #14): texel and pixel Samples skip them.
  return resampler_->MarkUnreliable(camera, &last_frame_);
}

absl::StatusOr<cv::Mat> FrameStream::Resample(int camera) {
  MVBRDF_RETURN_IF_ERROR(ReadFrame(camera));
  const resample::Resampler::RefusedObservations before = resampler_->Refused(camera);
  MVBRDF_ASSIGN_OR_RETURN(cv::Mat atlas, resampler_->ResampleCamera(camera, last_frame_));
  if (atlas_cache_ != nullptr) {
    const resample::Resampler::RefusedObservations after = resampler_->Refused(camera);
    const resample::Resampler::RefusedObservations refused{after.masked - before.masked,
                                                           after.saturated - before.saturated,
                                                           after.edge - before.edge, after.gradient - before.gradient,
                                                           after.kept - before.kept};
    atlas_cache_->Keep(frame_, camera, atlas_keys_[static_cast<size_t>(camera)], atlas, refused);
  }
  return atlas;
}

absl::StatusOr<cv::Mat> FrameStream::ResampledAtlas(int camera) {
  if (atlas_cache_ != nullptr && camera >= 0 && static_cast<size_t>(camera) < atlas_keys_.size()) {
    std::optional<ResampledAtlasCache::Kept> kept =
        atlas_cache_->Find(frame_, camera, atlas_keys_[static_cast<size_t>(camera)]);
    if (kept.has_value()) {
      AddRefused(kept->refused, &cached_refused_[static_cast<size_t>(camera)]);
      return std::move(kept->atlas);
    }
  }
  return Resample(camera);
}

resample::Resampler::RefusedObservations FrameStream::Refused(int camera) const {
  resample::Resampler::RefusedObservations sum = resampler_->Refused(camera);
  if (camera >= 0 && static_cast<size_t>(camera) < cached_refused_.size()) {
    AddRefused(cached_refused_[static_cast<size_t>(camera)], &sum);
  }
  return sum;
}

}  // namespace mvbrdf::pipeline
