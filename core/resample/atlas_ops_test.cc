#include "core/resample/atlas_ops.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/resample/resample_test_util.h"

namespace mvbrdf::resample {
namespace {

// Means of a few floats.
constexpr float kMeanTolerance = 1e-6f;

cv::Mat Invalid(int size) { return cv::Mat(size, size, CV_32FC4, cv::Scalar(0, 0, 0, 0)); }

void ExpectTexel(const cv::Mat& rgba, int x, int y, const cv::Vec4f& expected) {
  const cv::Vec4f& actual = rgba.at<cv::Vec4f>(y, x);
  for (int c = 0; c < 4; ++c) EXPECT_NEAR(actual[c], expected[c], kMeanTolerance) << "texel " << x << ", " << y;
}

TEST(GrowAtlasTest, SingleTexelGrowsToBlocks) {
  cv::Mat atlas = Invalid(9);
  const cv::Vec4f value(0.2f, 0.4f, 0.6f, 1.0f);
  atlas.at<cv::Vec4f>(4, 4) = value;
  for (int iterations : {0, 1, 2}) {
    const cv::Mat grown = GrowAtlas(atlas, iterations);
    for (int y = 0; y < 9; ++y) {
      for (int x = 0; x < 9; ++x) {
        const bool inside = std::abs(x - 4) <= iterations && std::abs(y - 4) <= iterations;
        ExpectTexel(grown, x, y, inside ? value : cv::Vec4f(0, 0, 0, 0));
      }
    }
  }
  // The input is not modified.
  EXPECT_EQ(cv::countNonZero(atlas.reshape(1)), 4);
}

TEST(GrowAtlasTest, GrownTexelsTakeTheMeanOfTheirValidNeighbours) {
  cv::Mat atlas = Invalid(9);
  const cv::Vec4f a(1.0f, 0.0f, 0.5f, 1.0f), b(0.0f, 1.0f, 0.25f, 1.0f);
  atlas.at<cv::Vec4f>(4, 3) = a;  // (x 3, y 4)
  atlas.at<cv::Vec4f>(4, 5) = b;  // (x 5, y 4)
  const cv::Mat once = GrowAtlas(atlas, 1);
  const cv::Vec4f mean((a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2, 1.0f);
  ExpectTexel(once, 4, 4, mean);  // between both
  ExpectTexel(once, 4, 3, mean);  // diagonal to both
  ExpectTexel(once, 2, 4, a);     // next to a only
  ExpectTexel(once, 6, 5, b);     // next to b only
  ExpectTexel(once, 3, 4, a);     // valid texels keep their value
  ExpectTexel(once, 1, 4, cv::Vec4f(0, 0, 0, 0));
  // Second ring: (1, 4) has the grown (2, 3), (2, 4), (2, 5), all equal to a.
  const cv::Mat twice = GrowAtlas(atlas, 2);
  ExpectTexel(twice, 1, 4, a);
  // (4, 2) sees (3, 3) = a, (4, 3) = mean, (5, 3) = b: their mean.
  ExpectTexel(twice, 4, 2,
              cv::Vec4f((a[0] + mean[0] + b[0]) / 3, (a[1] + mean[1] + b[1]) / 3, (a[2] + mean[2] + b[2]) / 3, 1.0f));
}

// Two quads side by side in UV space: 4 triangles with texels.
testing::QuadScene TwoQuads(int size) {
  testing::Quad left, right;
  left.uv_min = {0.05, 0.05};
  left.uv_max = {0.45, 0.95};
  right.uv_min = {0.55, 0.05};
  right.uv_max = {0.95, 0.95};
  return testing::MakeQuadScene({left, right}, size);
}

TEST(AverageTrianglesTest, MeansValidTexelsAndAppliesTheThreshold) {
  const testing::QuadScene scene = TwoQuads(32);
  const atlas::Atlas& atlas = scene.atlas;
  ASSERT_EQ(atlas.triangle_texels.size(), 4u);
  cv::Mat rgba = Invalid(32);
  // Triangle 0: all valid, value = (x, y, 1) / 32 per texel.
  // Triangle 1: exactly ceil(0.75 n) valid (passes the default threshold).
  // Triangle 2: one fewer than that (fails it); triangle 3: none valid.
  std::vector<int> num_valid(4);
  for (int t = 0; t < 4; ++t) {
    const int n = static_cast<int>(atlas.triangle_texels[t].size());
    ASSERT_GT(n, 20);
    const int at_threshold = static_cast<int>(std::ceil(0.75 * n));
    num_valid[t] = t == 0 ? n : t == 1 ? at_threshold : t == 2 ? at_threshold - 1 : 0;
  }
  std::vector<cv::Vec3d> sums(4, cv::Vec3d(0, 0, 0));
  for (int t = 0; t < 4; ++t) {
    for (int i = 0; i < num_valid[t]; ++i) {
      const uint32_t index = atlas.triangle_texels[t][i];
      const int x = static_cast<int>(index % 32), y = static_cast<int>(index / 32);
      const cv::Vec3f value(x / 32.0f, y / 32.0f, 1.0f);
      rgba.at<cv::Vec4f>(y, x) = cv::Vec4f(value[0], value[1], value[2], 1.0f);
      sums[t] += cv::Vec3d(value[0], value[1], value[2]);
    }
  }
  // An invalid texel's colour must not count.
  const uint32_t last = atlas.triangle_texels[1].back();
  rgba.at<cv::Vec4f>(last / 32, last % 32) = cv::Vec4f(100.0f, 100.0f, 100.0f, 0.0f);

  const std::vector<TriangleMean> means = AverageTriangles(rgba, atlas);
  ASSERT_EQ(means.size(), 4u);
  for (int t = 0; t < 4; ++t) {
    SCOPED_TRACE(::testing::Message() << "triangle " << t);
    EXPECT_EQ(means[t].texels, static_cast<int>(atlas.triangle_texels[t].size()));
    EXPECT_EQ(means[t].valid_texels, num_valid[t]);
    EXPECT_EQ(means[t].valid, t <= 1);
    if (num_valid[t] > 0) {
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(means[t].rgb[c], sums[t][c] / num_valid[t], kMeanTolerance);
    }
  }
  // A lower threshold admits triangle 2; a threshold of 0 still needs one valid texel.
  const std::vector<TriangleMean> lenient = AverageTriangles(rgba, atlas, 0.5f);
  EXPECT_TRUE(lenient[2].valid);
  const std::vector<TriangleMean> any = AverageTriangles(rgba, atlas, 0.0f);
  EXPECT_FALSE(any[3].valid);

  // The averaged atlas: each valid triangle's texels hold its mean; the rest a = 0.
  const cv::Mat averaged = AveragedAtlas(means, atlas);
  ASSERT_EQ(averaged.type(), CV_32FC4);
  for (int y = 0; y < 32; ++y) {
    for (int x = 0; x < 32; ++x) {
      const int t = atlas.triangle_id.at<int32_t>(y, x);
      if (t >= 0 && means[t].valid) {
        ExpectTexel(averaged, x, y, cv::Vec4f(means[t].rgb.x, means[t].rgb.y, means[t].rgb.z, 1.0f));
      } else {
        ExpectTexel(averaged, x, y, cv::Vec4f(0, 0, 0, 0));
      }
    }
  }
}

TEST(AveragedAtlasTest, SliverWithoutTexelsDoesNotOverwriteItsNeighbour) {
  // A big triangle and a sliver inside its texel (the sliver holds no texel
  // centre, so atlas.h gives it the texel under its UV centroid).
  atlas::Atlas atlas;
  atlas.size = 8;
  scene::MeshTopology& topo = atlas.topology;
  topo.uvs = {{0.0f, 0.0f}, {1.0f, 0.0f}, {0.0f, 1.0f}, {0.51f, 0.40f}, {0.52f, 0.40f}, {0.51f, 0.41f}};
  topo.triangles = {{0, 1, 2}, {3, 4, 5}};
  topo.file_triangles = topo.triangles;
  topo.render_to_file_vertex = {0, 1, 2, 3, 4, 5};
  topo.num_file_vertices = 6;
  atlas::RasterizeTriangles(&atlas);
  ASSERT_EQ(atlas.triangle_texels[1].size(), 1u);
  const uint32_t shared = atlas.triangle_texels[1][0];
  ASSERT_EQ(atlas.triangle_id.at<int32_t>(shared / 8, shared % 8), 0);
  std::vector<TriangleMean> means(2);
  means[0].rgb = glm::vec3(0.1f, 0.2f, 0.3f);
  means[0].valid = true;
  means[1].rgb = glm::vec3(0.9f);
  means[1].valid = true;
  const cv::Mat averaged = AveragedAtlas(means, atlas);
  ExpectTexel(averaged, shared % 8, shared / 8, cv::Vec4f(0.1f, 0.2f, 0.3f, 1.0f));
  // Alone, the sliver's texel takes its mean.
  means[0].valid = false;
  const cv::Mat alone = AveragedAtlas(means, atlas);
  ExpectTexel(alone, shared % 8, shared / 8, cv::Vec4f(0.9f, 0.9f, 0.9f, 1.0f));
}

}  // namespace
}  // namespace mvbrdf::resample
