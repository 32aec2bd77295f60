#include "client/output_dir.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace mvbrdf::client {
namespace {

namespace fs = std::filesystem;

class OutputDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("mvbrdf_output_dir_test_" + std::to_string(getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_ / "scene" / "videos");
    std::ofstream(root_ / "scene" / "scene.json") << "{}";
    inputs_ = {{"the scene file", root_ / "scene" / "scene.json", false},
               {"scene.cameras[0].video.path", root_ / "scene" / "videos" / "%04d.png", true}};
  }
  void TearDown() override { fs::remove_all(root_); }

  fs::path root_;
  std::vector<InputPath> inputs_;
};

TEST_F(OutputDirTest, RefusesADirectoryThatHoldsAnInput) {
  for (const fs::path& out : {root_ / "scene", root_, root_ / "scene" / "videos", root_ / "scene" / "videos" / "",
                              root_ / "scene" / "videos" / ".." / "videos", root_ / "elsewhere" / ".." / "scene"}) {
    const absl::Status s = CheckOutputDirSparesInputs("--out", out, inputs_);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << out;
    EXPECT_NE(s.message().find("--out "), std::string::npos) << s;
  }
  fs::create_directory_symlink(root_ / "scene", root_ / "link");
  EXPECT_FALSE(CheckOutputDirSparesInputs("--out", root_ / "link", inputs_).ok());
}

TEST_F(OutputDirTest, AcceptsDirectoriesBesideOrInsideTheScene) {
  // "scene2" shares a prefix with "scene" but is another directory.
  for (const fs::path& out : {root_ / "out", root_ / "scene2", root_ / "scene" / "run", root_ / "new" / "deeper"}) {
    EXPECT_TRUE(CheckOutputDirSparesInputs("--out", out, inputs_).ok()) << out;
  }
}

TEST_F(OutputDirTest, RefusesAFileThatIsAnInput) {
  EXPECT_FALSE(CheckOutputFileSparesInputs("--out", root_ / "scene" / "scene.json", inputs_).ok());
  EXPECT_FALSE(CheckOutputFileSparesInputs("--out", root_ / "scene" / "videos" / "0007.png", inputs_).ok());
  EXPECT_TRUE(CheckOutputFileSparesInputs("--out", root_ / "scene" / "videos" / "view.exr", inputs_).ok());
  EXPECT_TRUE(CheckOutputFileSparesInputs("--out", root_ / "scene" / "view.png", inputs_).ok());
}

TEST_F(OutputDirTest, OneLockPerDirectory) {
  const fs::path out = root_ / "out";
  absl::StatusOr<OutputDirLock> first = OutputDirLock::Acquire("--out", out);
  ASSERT_TRUE(first.ok()) << first.status();
  // flock locks belong to the open file: a second open, even in this process, is refused.
  absl::StatusOr<OutputDirLock> second = OutputDirLock::Acquire("--out", out);
  EXPECT_EQ(second.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_NE(second.status().message().find(out.string()), std::string::npos) << second.status();
  first = absl::UnavailableError("released");
  EXPECT_TRUE(OutputDirLock::Acquire("--out", out).ok());
}

}  // namespace
}  // namespace mvbrdf::client
