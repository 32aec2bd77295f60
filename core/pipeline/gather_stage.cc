#include "core/pipeline/gather_stage.h"

#include <algorithm>
#include <cmath>
#include <future>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/pipeline/atlas_parts.h"
#include "core/pipeline/frame_stream.h"
#include "core/resample/atlas_ops.h"
#include "core/samples/assemble.h"

namespace mvbrdf::pipeline {

absl::Status CheckPixelFootprint(int pixel_footprint, size_t num_lights) {
  const size_t copies = static_cast<size_t>(std::max(pixel_footprint, 1)) * static_cast<size_t>(std::max(pixel_footprint, 1));
  if (copies * num_lights <= static_cast<size_t>(samples::kMaxLights)) return absl::OkStatus();
  int most = 1;
  while (static_cast<size_t>((most + 1) * (most + 1)) * num_lights <= static_cast<size_t>(samples::kMaxLights)) ++most;
  return absl::InvalidArgumentError(absl::StrCat(
      "options.pixel_footprint (--pixel-footprint): ", pixel_footprint, " models each pixel with ", copies,
      " copies of each of the scene's ", num_lights, " lights, more than ", samples::kMaxLights,
      " in all; at most ", most, " for this scene"));
}

namespace {

// The assemblers' options of the gathering passes.
samples::AssembleOptions GatherAssembleOptions(const scene::Sequence& sequence, const ReconstructOptions& options) {
  samples::AssembleOptions assemble = options.assemble;
  assemble.inverse_square_falloff = sequence.scene.lighting().inverse_square_falloff();
  // The kept texel Samples of a half-vector model need the geometry.
  assemble.half_vector_geometry = options.GathersHalfVector();
  return assemble;
}

// A Sample holds only the lights on in its frame: the reservoir's rows are
// that long, not as long as the candidate list. With a pixel footprint each
// light has one copy per subpixel (samples::FootprintLights), and every term
// its a (the subpixel's share).
std::unique_ptr<TexelReservoir> MakeReservoir(const scene::Sequence& sequence, const ReconstructOptions& options,
                                              const samples::AssembleOptions& assemble, size_t num_texels) {
  const size_t num_lights = sequence.lights.size();
  const size_t copies = static_cast<size_t>(options.pixel_footprint) * static_cast<size_t>(options.pixel_footprint);
  const size_t max_terms = copies * samples::MaxLightsOn(samples::FrameLightMasks(sequence), num_lights);
  return std::make_unique<TexelReservoir>(num_texels, static_cast<int>(num_lights * copies), options.reservoir_uniform,
                                          options.reservoir_highlight, assemble.inverse_square_falloff || copies > 1,
                                          max_terms, options.GathersHalfVector());
}

// The cluster fits take per-pixel Samples: the video's own pixels at the
// exact surface points they show, so highlights reach ks and ke without the
// atlas's bilinear blur (measured: the blur alone made ke come out ~50 % low
// on 320x240 video). Camera c's of frame t: its surface (stream.Surface(c))
// and its video frame (stream.last_frame() after stream->Resample(c) or
// stream->ReadFrame(c)).
void OfferPixelSamples(const FrameStream& stream, const resample::CameraSurface& surface, const cv::Mat& frame,
                       const scene::Sequence& sequence, int t, int c, const samples::AssembleOptions& assemble,
                       const ReconstructOptions& options, TexelReservoir* reservoir) {
  const double min_cos_view = std::sin(options.resampler.grazing_margin_deg * 3.14159265358979 / 180.0);
  samples::ForEachPixelSample(
      frame, surface, stream.shadows(), sequence.cameras[static_cast<size_t>(c)], sequence.lights, assemble,
      min_cos_view,
      [&](uint32_t texel, const glm::vec3& rgb, const samples::LightTerms& terms) {
        reservoir->Offer(texel, t, c, rgb, terms);
      },
      options.pixel_footprint);
}

// The meshes of the frames the pass reads (every `stride`th) into the
// sequence's FrameCache, while they fit, before
// the pass allocates its sums and reservoir: the importer runs in a child
// forked per file (scene/mesh_loader.cc), and a fork costs in proportion to
// the process's memory (measured on bench-e2e's 40-frame actor: 78 ms per
// frame forked during the pass, 45 ms here, 25 ms in-process). A frame that
// cannot be read fails here, as the pass would have.
absl::Status PrefetchFrames(const scene::Sequence& sequence, int stride, const ReconstructOptions& options) {
  if (sequence.is_static_mesh() || sequence.frame_cache == nullptr) return absl::OkStatus();
  const size_t frame_bytes = sequence.rest_positions.size() * sizeof(glm::vec3);
  const size_t frames = (static_cast<size_t>(sequence.num_frames) + static_cast<size_t>(stride) - 1) / stride;
  if (frame_bytes * frames > scene::FrameCache::kDefaultBudgetBytes) {
    return absl::OkStatus();  // the pass reads the frames as it goes
  }
  for (int t = 0; t < sequence.num_frames; t += stride) {
    if (options.progress) options.progress("gather_samples", 0, sequence.num_frames);
    MVBRDF_RETURN_IF_ERROR(CheckCancelled(options));
    MVBRDF_RETURN_IF_ERROR(sequence.LoadFrame(t).status());
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::unique_ptr<TexelReservoir>> GatherPixelSamples(const scene::Sequence& sequence,
                                                                   gl::EglContext& context, const atlas::Atlas& atlas,
                                                                   const ReconstructOptions& options,
                                                                   ShadowAtlasCache* shadows,
                                                                   const std::vector<glm::vec3>& tangent_normals,
                                                                   const std::vector<uint8_t>& refined) {
  const samples::AssembleOptions assemble = GatherAssembleOptions(sequence, options);
  const size_t num_texels = static_cast<size_t>(atlas.size) * static_cast<size_t>(atlas.size);
  std::unique_ptr<TexelReservoir> reservoir = MakeReservoir(sequence, options, assemble, num_texels);
  MVBRDF_ASSIGN_OR_RETURN(auto stream, FrameStream::Open(sequence, context, atlas, options.resampler, shadows));
  stream->UseNormals(&tangent_normals, &refined);
  for (int t = 0; t < sequence.num_frames; ++t) {
    if (options.progress) options.progress("normals", t, sequence.num_frames);
    MVBRDF_RETURN_IF_ERROR(CheckCancelled(options));
    MVBRDF_RETURN_IF_ERROR(stream->SetFrame(t));
    for (int c = 0; c < static_cast<int>(sequence.cameras.size()); ++c) {
      MVBRDF_RETURN_IF_ERROR(stream->ReadFrame(c));
      MVBRDF_ASSIGN_OR_RETURN(const resample::CameraSurface surface, stream->Surface(c));
      OfferPixelSamples(*stream, surface, stream->last_frame(), sequence, t, c, assemble, options, reservoir.get());
    }
  }
  return reservoir;
}

absl::StatusOr<Gathered> GatherPass(const scene::Sequence& sequence, gl::EglContext& context,
                                    const atlas::Atlas& atlas, const ReconstructOptions& options, bool triangles,
                                    bool texels) {
  if (texels) MVBRDF_RETURN_IF_ERROR(CheckPixelFootprint(options.pixel_footprint, sequence.lights.size()));
  const int stride = SweepFrameStride(options, sequence.num_frames);
  MVBRDF_RETURN_IF_ERROR(PrefetchFrames(sequence, texels ? 1 : std::max(stride, 1), options));
  const samples::AssembleOptions assemble = GatherAssembleOptions(sequence, options);
  const size_t num_texels = static_cast<size_t>(atlas.size) * static_cast<size_t>(atlas.size);
  const size_t num_lights = sequence.lights.size();
  const int num_cameras = static_cast<int>(sequence.cameras.size());
  Gathered g;
  g.triangle_samples = samples::MakeSampleSet(sequence.lights, options.half_vector_geometry);
  if (texels) {
    g.texels = std::make_shared<TexelStatistics>();
    g.texels->texel_sum.assign(num_texels, glm::dvec3(0.0));
    g.texels->texel_count.assign(num_texels, 0);
    // The configurations the reconstruction may choose: every light (none
    // chosen, or per-frame lighting) and each of the scene's.
    std::vector<samples::LightMask> masks = {samples::AllLights(num_lights)};
    for (const v1::LightConfiguration& c : sequence.scene.light_configurations()) {
      MVBRDF_ASSIGN_OR_RETURN(const samples::LightMask mask,
                              g.triangle_samples.MaskOf({c.lights().begin(), c.lights().end()}));
      if (std::find(masks.begin(), masks.end(), mask) == masks.end()) masks.push_back(mask);
    }
    g.texels->illumination = TexelIllumination(num_texels, g.triangle_samples.light_intensity, std::move(masks));
    g.texels->reservoir = MakeReservoir(sequence, options, assemble, num_texels);
  }
  TexelStatistics* st = g.texels.get();
  if (st != nullptr) {
    st->shadow_atlases = std::make_shared<ShadowAtlasCache>();
    // Without a temporary file the later passes resample again: slower, the same result.
    absl::StatusOr<std::unique_ptr<ResampledAtlasCache>> atlases = ResampledAtlasCache::Create();
    if (atlases.ok()) st->resampled_atlases = *std::move(atlases);
  }
  // A footprint's subpixels read their rays' own triangles (SurfaceOnRay).
  resample::ResamplerOptions resampler = options.resampler;
  resampler.surface_triangles = texels && options.pixel_footprint > 1;
  MVBRDF_ASSIGN_OR_RETURN(auto stream,
                          FrameStream::Open(sequence, context, atlas, resampler,
                                            st != nullptr ? st->shadow_atlases.get() : nullptr,
                                            st != nullptr ? st->resampled_atlases.get() : nullptr));
  const std::vector<uint8_t> own_frames = samples::OwnLightingFrames(sequence);
  for (int t = 0; t < sequence.num_frames; ++t) {
    if (options.progress) options.progress("gather_samples", t, sequence.num_frames);
    MVBRDF_RETURN_IF_ERROR(CheckCancelled(options));
    const bool sweep_frame = triangles && t % stride == 0;
    if (!sweep_frame && !texels) continue;
    MVBRDF_RETURN_IF_ERROR(stream->SetFrame(t));
    const bool own_lit = t < static_cast<int>(own_frames.size()) && own_frames[static_cast<size_t>(t)] != 0;
    if (t == 0) {
      g.rest_position = stream->geometry().position.clone();
      if (st != nullptr) st->rest_position = g.rest_position;
    }
    // The GL work of camera c + 1 (video, depth map, resampling, read-back)
    // overlaps the CPU work of camera c (its triangle Samples, texel sums and
    // pixel Samples) on a thread of its own: serially, llvmpipe's threads
    // waited while the GL thread ran the CPU part and the other way round
    // (~1.5 of 2 cores busy; 40-frame actor: gather 17.1-20.0 s serial,
    // 13.9-15.0 s overlapped). The CPU parts run one camera at a time in camera
    // order, so every sum and Sample is as a single thread makes it; they read
    // the frame's geometry, shadows and positions, which stay until the next
    // SetFrame (after `pending` is done).
    std::future<void> pending;
    for (int c = 0; c < num_cameras; ++c) {
      MVBRDF_ASSIGN_OR_RETURN(cv::Mat resampled, stream->Resample(c));
      resample::CameraSurface surface;
      cv::Mat frame;
      if (st != nullptr) {
        MVBRDF_ASSIGN_OR_RETURN(surface, stream->Surface(c));
        frame = stream->last_frame();  // a fresh image per read (VideoSource::ReadFrame)
      }
      if (pending.valid()) pending.get();
      pending = std::async(std::launch::async, [&, c, resampled = std::move(resampled), surface = std::move(surface),
                                                frame = std::move(frame)] {
        if (sweep_frame) {
          const auto means = resample::AverageTriangles(resampled, atlas, options.min_valid_fraction);
          samples::AppendTriangleSamples(means, atlas, stream->positions(), stream->shadows(), sequence.cameras[c], c,
                                         t, sequence.lights, assemble, &g.triangle_samples);
        }
        if (st == nullptr) return;
        // Per-texel sums only: in parts on threads (atlas_parts.h).
        if (own_lit) st->illumination.ReserveOwn();
        InAtlasParts([&](int part) {
          samples::ForEachTexelSample(
              resampled, stream->geometry(), stream->shadows(), sequence.cameras[c], sequence.lights, assemble,
              [&](uint32_t texel, const glm::vec3& rgb, const samples::LightTerms& terms) {
                st->texel_sum[texel] += glm::dvec3(rgb);
                ++st->texel_count[texel];
                st->illumination.Add(texel, terms, own_lit);
              },
              AtlasPartRows(part, atlas.size));
        });
        OfferPixelSamples(*stream, surface, frame, sequence, t, c, assemble, options, st->reservoir.get());
      });
    }
    if (pending.valid()) pending.get();
  }
  if (options.progress) options.progress("gather_samples", sequence.num_frames, sequence.num_frames);
  return g;
}

void NoteSweepFrames(const ReconstructOptions& options, int num_frames, v1::Plan* plan) {
  const int stride = SweepFrameStride(options, num_frames);
  if (stride <= 1) return;
  for (v1::PlannedStage& stage : *plan->mutable_stages()) {
    if (stage.name() != "light_sweep") continue;
    stage.set_why(absl::StrCat(stage.why(), " on every ", stride, options.sweep_frame_stride > 0 ? "" : " (automatic)",
                               "th frame (", (num_frames + stride - 1) / stride, " of ", num_frames, ")"));
  }
}

absl::StatusOr<samples::SampleSet> GatherTriangleSamples(const scene::Sequence& sequence, gl::EglContext& context,
                                                         const ReconstructOptions& options) {
  MVBRDF_ASSIGN_OR_RETURN(const atlas::Atlas atlas,
                          atlas::BuildAtlas(sequence.topology, sequence.rest_positions, options.atlas));
  MVBRDF_ASSIGN_OR_RETURN(Gathered g, GatherPass(sequence, context, atlas, options, true, false));
  return std::move(g.triangle_samples);
}

}  // namespace mvbrdf::pipeline
