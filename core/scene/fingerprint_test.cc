#include "core/scene/fingerprint.h"

#include <gtest/gtest.h>

#include "core/scene/scene_test_util.h"

namespace mvbrdf::scene {
namespace {

using testing::FixtureScene;
using testing::TempDir;
using testing::WriteFixture;
using testing::WriteText;

// Issue #19 defect 9: `evaluate --truth` of another scene said
// "configurationCorrect": true. The fingerprint tells scenes apart.
TEST(FingerprintTest, SameSceneMatchesAndEachDifferenceIsNamed) {
  TempDir dir;
  auto seq = LoadSequence(WriteFixture(dir.path(), FixtureScene()));
  ASSERT_TRUE(seq.ok()) << seq.status();
  const v1::SceneFingerprint a = Fingerprint(*seq);
  EXPECT_EQ(a.mesh_triangles(), static_cast<uint64_t>(testing::kFixtureTriangles));
  EXPECT_EQ(a.mesh_vertices(), 5u);
  EXPECT_EQ(a.mesh_hash().size(), 16u);
  ASSERT_EQ(a.cameras_size(), 2);
  EXPECT_TRUE(CompareFingerprints(a, a, "the run", "the truth").ok());

  // Another mesh of the same size: frame 1's pyramid as frame 0.
  WriteText(dir / "mesh_0000.obj", testing::PyramidObj(1));
  auto moved = LoadSequence(dir / "scene.json");
  ASSERT_TRUE(moved.ok()) << moved.status();
  absl::Status s = CompareFingerprints(a, Fingerprint(*moved), "the run", "the truth");
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("meshes (frame 0's positions or triangles) differ: the run has fingerprint"),
            std::string::npos)
      << s.message();

  v1::SceneFingerprint b = a;
  b.set_mesh_triangles(7);
  s = CompareFingerprints(a, b, "the run", "the truth");
  EXPECT_NE(s.message().find("mesh triangle counts differ: the run has 6, the truth has 7"), std::string::npos)
      << s.message();
  b = a;
  b.mutable_cameras(1)->set_name("other");
  s = CompareFingerprints(a, b, "the run", "the truth");
  EXPECT_NE(s.message().find("cameras[1] names differ: the run has \"cam1\", the truth has \"other\""),
            std::string::npos)
      << s.message();
  b = a;
  b.mutable_cameras(0)->set_fx(b.cameras(0).fx() + 1);
  s = CompareFingerprints(a, b, "the run", "the truth");
  EXPECT_NE(s.message().find("camera \"cam0\": intrinsics (fx, fy, cx, cy) differ"), std::string::npos) << s.message();
  // Issue #13: the camera model and pixel size (an orthographic camera taken
  // for a pinhole is another scene).
  v1::Camera ortho = seq->scene.cameras(0);
  ortho.set_model(v1::ORTHOGRAPHIC);
  ortho.set_pixel_size(0.01);
  b = a;
  *b.mutable_cameras(0) = CameraFingerprintOf(ortho);
  s = CompareFingerprints(a, b, "the run", "the truth");
  EXPECT_NE(s.message().find("camera \"cam0\": camera models differ: the run has pinhole, the truth has orthographic"),
            std::string::npos)
      << s.message();
  v1::SceneFingerprint c = b;
  c.mutable_cameras(0)->set_pixel_size(0.02);
  s = CompareFingerprints(b, c, "the run", "the truth");
  EXPECT_NE(s.message().find("camera \"cam0\": pixel sizes differ: the run has 0.01, the truth has 0.02"),
            std::string::npos)
      << s.message();
  // PINHOLE and unspecified are the same model.
  v1::Camera pinhole = seq->scene.cameras(0);
  pinhole.set_model(v1::PINHOLE);
  b = a;
  *b.mutable_cameras(0) = CameraFingerprintOf(pinhole);
  EXPECT_TRUE(CompareFingerprints(a, b, "the run", "the truth").ok());
  b = a;
  b.mutable_cameras()->RemoveLast();
  EXPECT_NE(CompareFingerprints(a, b, "the run", "the truth").message().find("camera counts differ"),
            std::string::npos);
  // What an older file lacks is not compared.
  b = v1::SceneFingerprint();
  b.set_mesh_triangles(6);
  EXPECT_TRUE(CompareFingerprints(a, b, "the run", "the truth").ok());
}

}  // namespace
}  // namespace mvbrdf::scene
