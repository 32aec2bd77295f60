// FrameStream on a generated one-light-at-a-time sequence: the shadow atlas
// of each frame holds only the lights on in it (issue #13), so every Sample
// assembled from it knows its frame's lights; a second pass takes them from
// the first's ShadowAtlasCache, and its resampled atlases from the first's
// ResampledAtlasCache.
#include "core/pipeline/frame_stream.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <utility>
#include <vector>

#include "core/base/status_macros.h"
#include "core/synth/synthesizer.h"

namespace mvbrdf::pipeline {
namespace {

// OR of every texel's bits.
uint32_t BitsSeen(const cv::Mat& shadows) {
  uint32_t bits = 0;
  for (int r = 0; r < shadows.rows; ++r) {
    for (int c = 0; c < shadows.cols; ++c) bits |= shadows.at<uint16_t>(r, c);
  }
  return bits;
}

// A generated sequence (so.out_dir; 3 frames of an 8-segment actor) and its
// 128^2 atlas.
struct Generated {
  scene::Sequence sequence;
  atlas::Atlas atlas;
};
absl::StatusOr<Generated> Generate(gl::EglContext& context, synth::SynthOptions so) {
  so.num_frames = 3;
  so.actor_segments = 8;
  so.shadow_map_size = 128;
  MVBRDF_ASSIGN_OR_RETURN(const auto synthesized, synth::Synthesize(so, context));
  Generated g;
  MVBRDF_ASSIGN_OR_RETURN(g.sequence, scene::LoadSequence(synthesized.scene_file));
  atlas::AtlasOptions ao;
  ao.size = 128;
  MVBRDF_ASSIGN_OR_RETURN(g.atlas, atlas::BuildAtlas(g.sequence.topology, g.sequence.rest_positions, ao));
  return g;
}

TEST(FrameStreamTest, ShadowBitsHoldOnlyEachFramesOwnLights) {
  auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
  ASSERT_TRUE(context.ok()) << context.status();
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("mvbrdf_frame_stream_test_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  for (const synth::Lighting lighting : {synth::Lighting::kStudio, synth::Lighting::kOlat}) {
    synth::SynthOptions so;
    so.num_cameras = 1;
    so.width = 64;
    so.height = 48;
    so.lighting = lighting;
    so.out_dir = dir / (lighting == synth::Lighting::kOlat ? "olat" : "studio");
    auto generated = Generate(**context, so);
    ASSERT_TRUE(generated.ok()) << generated.status();
    const scene::Sequence* sequence = &generated->sequence;
    const atlas::Atlas* atlas = &generated->atlas;
    // The first stream keeps its shadow atlases in `kept`; the second takes
    // them from it: the same atlases as computed.
    ShadowAtlasCache kept;
    auto stream = FrameStream::Open(*sequence, **context, *atlas, {}, &kept);
    ASSERT_TRUE(stream.ok()) << stream.status();
    auto second = FrameStream::Open(*sequence, **context, *atlas, {}, &kept);
    ASSERT_TRUE(second.ok()) << second.status();
    const std::vector<samples::LightMask> on = samples::FrameLightMasks(*sequence);
    for (int t = 0; t < 3; ++t) {
      ASSERT_TRUE((*stream)->SetFrame(t).ok());
      EXPECT_EQ(kept.size(), static_cast<size_t>(t + 1));
      ASSERT_TRUE((*second)->SetFrame(t).ok());
      EXPECT_EQ(cv::norm((*second)->shadows(), (*stream)->shadows(), cv::NORM_INF), 0.0) << "frame " << t;
      const uint32_t seen = BitsSeen((*stream)->shadows());
      if (lighting == synth::Lighting::kOlat) {
        // Frame t: light t (C, N, E) alone.
        EXPECT_EQ(on[static_cast<size_t>(t)], samples::LightMask::FromBits(1u << t));
        EXPECT_EQ(seen, 1u << t) << "frame " << t;
      } else {
        // Every light lights some texel: nothing is masked.
        EXPECT_EQ(on[static_cast<size_t>(t)], samples::LightMask::FromBits(0x1ffu));
        EXPECT_EQ(seen, 0x1ffu) << "frame " << t;
      }
    }
    EXPECT_FALSE((*stream)->SetFrame(3).ok());
  }
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}

bool BitForBit(const cv::Mat& a, const cv::Mat& b) {
  return a.type() == b.type() && a.size() == b.size() && std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

TEST(FrameStreamTest, ALaterPassReadsTheFirstPassesAtlasesBitForBitWithoutTheVideo) {
  auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
  ASSERT_TRUE(context.ok()) << context.status();
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("mvbrdf_frame_stream_atlases_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  synth::SynthOptions so;
  so.num_cameras = 2;
  so.width = 96;
  so.height = 72;
  so.out_dir = dir;
  auto generated = Generate(**context, so);
  ASSERT_TRUE(generated.ok()) << generated.status();
  const scene::Sequence* sequence = &generated->sequence;
  const atlas::Atlas* atlas = &generated->atlas;
  // Edges and gradients refused, so that the counts are not all zero.
  resample::ResamplerOptions options;
  options.edge_margin_pixels = 1.5;
  options.gradient_rejection = 0.5;
  auto cache = ResampledAtlasCache::Create();
  ASSERT_TRUE(cache.ok()) << cache.status();
  auto first = FrameStream::Open(*sequence, **context, *atlas, options, nullptr, cache->get());
  ASSERT_TRUE(first.ok()) << first.status();
  std::vector<cv::Mat> computed;
  for (int t = 0; t < 3; ++t) {
    ASSERT_TRUE((*first)->SetFrame(t).ok());
    for (int c = 0; c < 2; ++c) {
      auto a = (*first)->Resample(c);
      ASSERT_TRUE(a.ok()) << a.status();
      computed.push_back(*a);
    }
  }
  EXPECT_EQ((*cache)->size(), 6u);
  const auto refused = [](const FrameStream& s, int c) {
    const resample::Resampler::RefusedObservations r = s.Refused(c);
    return std::vector<uint64_t>{r.masked, r.saturated, r.edge, r.gradient, r.kept};
  };
  EXPECT_GT(refused(**first, 0)[2] + refused(**first, 0)[3], 0u);

  auto second = FrameStream::Open(*sequence, **context, *atlas, options, nullptr, cache->get());
  ASSERT_TRUE(second.ok()) << second.status();
  for (int t = 0; t < 3; ++t) {
    ASSERT_TRUE((*second)->SetFrame(t).ok());
    for (int c = 0; c < 2; ++c) {
      auto a = (*second)->ResampledAtlas(c);
      ASSERT_TRUE(a.ok()) << a.status();
      EXPECT_TRUE(BitForBit(*a, computed[static_cast<size_t>(2 * t + c)])) << "frame " << t << " camera " << c;
    }
  }
  // No video frame was read, and the refused observations count as if it had resampled.
  EXPECT_TRUE((*second)->last_frame().empty());
  for (int c = 0; c < 2; ++c) EXPECT_EQ(refused(**second, c), refused(**first, c)) << "camera " << c;

  // Another calibration of camera 0 or other resampler options: resampled.
  scene::Sequence moved = *sequence;
  moved.cameras[0].fx *= 1.001;
  resample::ResamplerOptions other = options;
  other.edge_margin_pixels = 0.0;
  for (const auto& [seq, opts] :
       {std::pair{static_cast<const scene::Sequence*>(&moved), options}, std::pair{sequence, other}}) {
    auto third = FrameStream::Open(*seq, **context, *atlas, opts, nullptr, cache->get());
    ASSERT_TRUE(third.ok()) << third.status();
    ASSERT_TRUE((*third)->SetFrame(1).ok());
    auto a = (*third)->ResampledAtlas(0);
    ASSERT_TRUE(a.ok()) << a.status();
    EXPECT_FALSE((*third)->last_frame().empty());
    EXPECT_FALSE(BitForBit(*a, computed[2])) << (seq == &moved ? "moved camera" : "other options");
  }
  EXPECT_EQ((*cache)->size(), 6u);
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}

}  // namespace
}  // namespace mvbrdf::pipeline
