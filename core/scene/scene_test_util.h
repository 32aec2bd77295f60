// Small on-disk fixtures for the core/scene tests: a temporary directory and a
// valid tiny scene (a few triangles, 2 cameras, 4 PNG frames each).
#ifndef MVBRDF_CORE_SCENE_SCENE_TEST_UTIL_H_
#define MVBRDF_CORE_SCENE_SCENE_TEST_UTIL_H_

#include <filesystem>
#include <string>

#include "mvbrdf/v1/scene.pb.h"

namespace mvbrdf::scene::testing {

// A fresh directory under the system temp dir, removed on destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& relative) const { return path_ / relative; }

 private:
  std::filesystem::path path_;
};

// Writes `text` to `file` (creating directories); fails the test on error.
void WriteText(const std::filesystem::path& file, const std::string& text);

// The tiny scene: a per-frame mesh "mesh_%04d.obj" (a square pyramid, 6
// triangles, moving along x), frames 0..3 at 25 fps, cameras "cam0" and "cam1"
// (32x24 PNG sequences "cam0/%04d.png"), point lights "NE" and "NW", a
// directional light "sun", two configurations, one frame-lighting entry, two
// material seeds and a segmentation.
constexpr int kFixtureFrames = 4;
constexpr int kFixtureWidth = 32;
constexpr int kFixtureHeight = 24;
constexpr int kFixtureTriangles = 6;
v1::Scene FixtureScene();

// Writes the fixture's files (meshes, frames, segmentation) and `scene` as
// dir/scene.json; returns the scene file.
std::filesystem::path WriteFixture(const std::filesystem::path& dir, const v1::Scene& scene);

// The pyramid of frame `frame` as OBJ text (shifted by 0.1 * frame along x).
std::string PyramidObj(int frame);

}  // namespace mvbrdf::scene::testing

#endif  // MVBRDF_CORE_SCENE_SCENE_TEST_UTIL_H_
