// FrameStream on a generated one-light-at-a-time sequence: the shadow atlas
// of each frame holds only the lights on in it (issue #13), so every Sample
// assembled from it knows its frame's lights; a second pass takes them from
// the first's ShadowAtlasCache.
#include "core/pipeline/frame_stream.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

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

TEST(FrameStreamTest, ShadowBitsHoldOnlyEachFramesOwnLights) {
  auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
  ASSERT_TRUE(context.ok()) << context.status();
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("mvbrdf_frame_stream_test_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  for (const synth::Lighting lighting : {synth::Lighting::kStudio, synth::Lighting::kOlat}) {
    synth::SynthOptions so;
    so.num_cameras = 1;
    so.num_frames = 3;
    so.width = 64;
    so.height = 48;
    so.actor_segments = 8;
    so.shadow_map_size = 128;
    so.lighting = lighting;
    so.out_dir = dir / (lighting == synth::Lighting::kOlat ? "olat" : "studio");
    auto synthesized = synth::Synthesize(so, **context);
    ASSERT_TRUE(synthesized.ok()) << synthesized.status();
    auto sequence = scene::LoadSequence(synthesized->scene_file);
    ASSERT_TRUE(sequence.ok()) << sequence.status();
    atlas::AtlasOptions ao;
    ao.size = 128;
    auto atlas = atlas::BuildAtlas(sequence->topology, sequence->rest_positions, ao);
    ASSERT_TRUE(atlas.ok()) << atlas.status();
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

}  // namespace
}  // namespace mvbrdf::pipeline
