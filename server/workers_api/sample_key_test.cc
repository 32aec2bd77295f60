#include "server/workers_api/sample_key.h"

#include <functional>
#include <string>

#include <gtest/gtest.h>

#include "server/store/digest.h"

namespace mvbrdf::server {
namespace {

const std::string kBundle(64, 'b');

TEST(TriangleSampleKeyTest, OneEntryPerBundleAndAtlasSizeForEveryConfiguration) {
  v1::SubmitJobRequest request;
  request.set_bundle_sha256(kBundle);
  request.add_configurations("key+fill");
  const store::SampleKey key = TriangleSampleKey(kBundle, request);
  EXPECT_EQ(key.sequence_hash, kBundle);
  EXPECT_EQ(key.configuration, "*");
  EXPECT_EQ(key.sample_level, 0);
  // atlas_size 0 means the default, 512.
  EXPECT_EQ(TriangleSampleOptions(request),
            "triangle-samples/"
            "v3;atlas_size=512;sweep_frame_stride=auto;refine_cameras=auto;refine_focal=0;refine_distortion=0;refine_"
            "frames=default;edge_margin=default;gradient_rejection=default");
  EXPECT_EQ(key.options_hash,
            store::Sha256Hex("triangle-samples/"
                             "v3;atlas_size=512;sweep_frame_stride=auto;refine_cameras=auto;refine_focal=0;refine_"
                             "distortion=0;refine_frames=default;edge_margin=default;gradient_rejection=default"));

  // Other configurations and fitting options that do not change the
  // Samples: the same entry.
  v1::SubmitJobRequest other = request;
  other.clear_configurations();
  other.set_configuration("key");
  other.mutable_options()->set_atlas_size(512);
  other.mutable_options()->set_max_iterations(7);
  EXPECT_EQ(TriangleSampleKey(kBundle, other).ToString(), key.ToString());

  // Another atlas size or bundle: another entry.
  other.mutable_options()->set_atlas_size(256);
  EXPECT_EQ(TriangleSampleKey(kBundle, other).options_hash,
            store::Sha256Hex("triangle-samples/"
                             "v3;atlas_size=256;sweep_frame_stride=auto;refine_cameras=auto;refine_focal=0;refine_"
                             "distortion=0;refine_frames=default;edge_margin=default;gradient_rejection=default"));
  EXPECT_NE(TriangleSampleKey(std::string(64, 'c'), request).ToString(), key.ToString());
}

TEST(TriangleSampleKeyTest, FrameStrideAndSceneFileChangeTheKey) {
  v1::SubmitJobRequest request;
  request.set_scene_path("scene.json");  // the default file, named
  request.mutable_options()->set_refine_cameras(v1::REFINEMENT_OFF);
  // 1 (every frame) is not 0 (automatic: at most 64 frames).
  request.mutable_options()->set_sweep_frame_stride(1);
  EXPECT_EQ(TriangleSampleOptions(request),
            "triangle-samples/"
            "v3;atlas_size=512;sweep_frame_stride=1;refine_cameras=off;edge_margin=default;gradient_rejection=default");
  request.mutable_options()->set_sweep_frame_stride(4);
  EXPECT_EQ(TriangleSampleOptions(request),
            "triangle-samples/"
            "v3;atlas_size=512;sweep_frame_stride=4;refine_cameras=off;edge_margin=default;gradient_rejection=default");
  request.set_scene_path("takes/b.json");
  EXPECT_EQ(TriangleSampleOptions(request),
            "triangle-samples/"
            "v3;atlas_size=512;sweep_frame_stride=4;refine_cameras=off;edge_margin=default;gradient_rejection=default;"
            "scene_path=takes/b.json");
  EXPECT_EQ(TriangleSampleKey(kBundle, request).options_hash, store::Sha256Hex(TriangleSampleOptions(request)));
}

// Issue #14: the camera refinement resamples with other cameras, rejection
// drops observations: each option that changes the Samples changes the key.
TEST(TriangleSampleKeyTest, RefinementAndRejectionChangeTheKey) {
  v1::SubmitJobRequest request;
  const std::string base = TriangleSampleKey(kBundle, request).options_hash;
  const auto differs = [&](const std::function<void(v1::FittingOptions*)>& change) {
    v1::SubmitJobRequest other = request;
    change(other.mutable_options());
    return TriangleSampleKey(kBundle, other).options_hash != base;
  };
  EXPECT_TRUE(differs([](v1::FittingOptions* o) { o->set_refine_cameras(v1::REFINEMENT_OFF); }));
  EXPECT_TRUE(differs([](v1::FittingOptions* o) { o->set_refine_cameras(v1::REFINEMENT_ON); }));
  EXPECT_TRUE(differs([](v1::FittingOptions* o) { o->set_refine_focal(true); }));
  EXPECT_TRUE(differs([](v1::FittingOptions* o) { o->set_refine_distortion(true); }));
  EXPECT_TRUE(differs([](v1::FittingOptions* o) { o->set_refine_photometric(true); }));
  EXPECT_TRUE(differs([](v1::FittingOptions* o) { o->set_refine_frames(4); }));
  EXPECT_TRUE(differs([](v1::FittingOptions* o) { o->set_edge_margin_pixels(2.0); }));
  EXPECT_TRUE(differs([](v1::FittingOptions* o) { o->set_gradient_rejection(0.5); }));
  EXPECT_FALSE(differs([](v1::FittingOptions* o) { o->set_refine_lights(v1::REFINEMENT_OFF); }));
  // The calibration sits beside the Samples under its own level.
  const store::SampleKey calibration = CalibrationKey(kBundle, request);
  EXPECT_EQ(calibration.sample_level, kCalibrationLevel);
  EXPECT_EQ(calibration.options_hash, base);
}

}  // namespace
}  // namespace mvbrdf::server
