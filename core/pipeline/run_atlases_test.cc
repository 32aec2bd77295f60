#include "core/pipeline/run_atlases.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include "core/image/exr.h"

namespace mvbrdf::pipeline {
namespace {

class GgxSupportAtlasTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("mvbrdf_run_atlases_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_ / "atlases");
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  // An 8x8 cluster atlas: columns 0-2 cluster 0, 5-7 cluster 1, 3-4 none.
  void WriteClusters() {
    cv::Mat cluster(8, 8, CV_32SC1, cv::Scalar(-1));
    cluster.colRange(0, 3).setTo(0);
    cluster.colRange(5, 8).setTo(1);
    ASSERT_TRUE(image::WriteExr(dir_ / "atlases" / "cluster.exr", cluster).ok());
  }

  std::filesystem::path dir_;
};

TEST_F(GgxSupportAtlasTest, EachTexelHoldsItsClustersSupportGrownIntoTheGutter) {
  WriteClusters();
  v1::RunReport run;
  run.add_clusters()->set_ggx_grazing_support(0.25);  // a GGX cluster
  run.add_clusters();                                   // e.g. Phong under auto: none
  run.mutable_options()->mutable_fitting()->set_grow_iterations(1);
  const absl::StatusOr<cv::Mat> atlas = GgxSupportAtlas(dir_, run, 8);
  ASSERT_TRUE(atlas.ok()) << atlas.status();
  ASSERT_EQ(atlas->type(), CV_32FC3);
  for (int y = 0; y < 8; ++y) {
    EXPECT_FLOAT_EQ(atlas->at<cv::Vec3f>(y, 1)[0], 0.25f);
    EXPECT_FLOAT_EQ(atlas->at<cv::Vec3f>(y, 1)[2], 0.25f);
    EXPECT_FLOAT_EQ(atlas->at<cv::Vec3f>(y, 6)[0], 0.0f);
    EXPECT_FLOAT_EQ(atlas->at<cv::Vec3f>(y, 3)[0], 0.25f);  // grown one texel from cluster 0
  }
}

TEST_F(GgxSupportAtlasTest, EmptyWithoutAnySupportAndRefusesABadClusterAtlas) {
  WriteClusters();
  v1::RunReport run;
  run.add_clusters();
  run.add_clusters();
  const absl::StatusOr<cv::Mat> none = GgxSupportAtlas(dir_, run, 8);
  ASSERT_TRUE(none.ok()) << none.status();
  EXPECT_TRUE(none->empty());
  // Cluster 1 is not in a report of one cluster; a size that is not the atlas's.
  v1::RunReport one;
  one.add_clusters()->set_ggx_grazing_support(0.25);
  const absl::Status unknown = GgxSupportAtlas(dir_, one, 8).status();
  EXPECT_NE(unknown.message().find("names cluster 1 of 1"), std::string::npos) << unknown;
  run.mutable_clusters(0)->set_ggx_grazing_support(0.25);
  const absl::Status size = GgxSupportAtlas(dir_, run, 16).status();
  EXPECT_NE(size.message().find("cluster.exr: not the kd atlas's size"), std::string::npos) << size;
}

}  // namespace
}  // namespace mvbrdf::pipeline
