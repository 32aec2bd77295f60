#include "server/workers_api/sample_key.h"

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
  EXPECT_EQ(TriangleSampleOptions(request), "triangle-samples/v2;atlas_size=512;sweep_frame_stride=auto");
  EXPECT_EQ(key.options_hash, store::Sha256Hex("triangle-samples/v2;atlas_size=512;sweep_frame_stride=auto"));

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
  EXPECT_EQ(TriangleSampleKey(kBundle, other).options_hash, store::Sha256Hex("triangle-samples/v2;atlas_size=256;sweep_frame_stride=auto"));
  EXPECT_NE(TriangleSampleKey(std::string(64, 'c'), request).ToString(), key.ToString());
}

TEST(TriangleSampleKeyTest, FrameStrideAndSceneFileChangeTheKey) {
  v1::SubmitJobRequest request;
  request.set_scene_path("scene.json");  // the default file, named
  // 1 (every frame) is not 0 (automatic: at most 64 frames).
  request.mutable_options()->set_sweep_frame_stride(1);
  EXPECT_EQ(TriangleSampleOptions(request), "triangle-samples/v2;atlas_size=512;sweep_frame_stride=1");
  request.mutable_options()->set_sweep_frame_stride(4);
  EXPECT_EQ(TriangleSampleOptions(request), "triangle-samples/v2;atlas_size=512;sweep_frame_stride=4");
  request.set_scene_path("takes/b.json");
  EXPECT_EQ(TriangleSampleOptions(request),
            "triangle-samples/v2;atlas_size=512;sweep_frame_stride=4;scene_path=takes/b.json");
  EXPECT_EQ(TriangleSampleKey(kBundle, request).options_hash, store::Sha256Hex(TriangleSampleOptions(request)));
}

}  // namespace
}  // namespace mvbrdf::server
