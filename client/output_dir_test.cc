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

// Issue #20 item 3: a used --out is refused unless --force, which clears only
// a directory an mvbrdf command wrote (it holds kOutputMarker).
TEST_F(OutputDirTest, PrepareRefusesAUsedDirectoryAndForceClearsOnlyMarkedOnes) {
  const fs::path out = root_ / "out";
  {
    absl::StatusOr<OutputDirLock> lock = PrepareOutputDir("--out", out, false);  // new: created and marked
    ASSERT_TRUE(lock.ok()) << lock.status();
    EXPECT_TRUE(fs::exists(out / kOutputMarker));
  }
  EXPECT_TRUE(PrepareOutputDir("--out", out, false).ok()) << "only the marker and the lock: empty";
  fs::create_directories(out / "atlases" / "correction");
  std::ofstream(out / "atlases" / "correction" / "0003.exr") << "stale";
  // A link to a precious directory inside an output: removed, not followed.
  fs::create_directories(root_ / "precious");
  std::ofstream(root_ / "precious" / "keep.txt") << "keep";
  fs::create_directory_symlink(root_ / "precious", out / "link");
  absl::StatusOr<OutputDirLock> refused = PrepareOutputDir("--out", out, false);
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(refused.status().message().find("--force"), std::string::npos) << refused.status();
  EXPECT_TRUE(fs::exists(out / "atlases" / "correction" / "0003.exr"));
  {
    absl::StatusOr<OutputDirLock> forced = PrepareOutputDir("--out", out, true);
    ASSERT_TRUE(forced.ok()) << forced.status();
  }
  EXPECT_FALSE(fs::exists(out / "atlases"));
  EXPECT_FALSE(fs::exists(out / "link"));
  EXPECT_TRUE(fs::exists(root_ / "precious" / "keep.txt"));
  EXPECT_TRUE(fs::exists(out / kOutputMarker));

  // Not written by mvbrdf: refused even with --force, naming a file; nothing
  // deleted, nothing created.
  const fs::path home = root_ / "home";
  fs::create_directories(home);
  std::ofstream(home / ".bashrc") << "x";
  for (bool force : {false, true}) {
    absl::StatusOr<OutputDirLock> s = PrepareOutputDir("--out", home, force);
    EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(s.status().message().find(".bashrc"), std::string::npos) << s.status();
  }
  EXPECT_TRUE(fs::exists(home / ".bashrc"));
  EXPECT_FALSE(fs::exists(home / kOutputMarker));
  EXPECT_FALSE(fs::exists(home / ".mvbrdf.lock"));
}

TEST_F(OutputDirTest, PrepareOfADirectoryBeingWrittenSaysSo) {
  const fs::path out = root_ / "busy";
  absl::StatusOr<OutputDirLock> first = PrepareOutputDir("--out", out, false);
  ASSERT_TRUE(first.ok()) << first.status();
  std::ofstream(out / "result.json") << "{}";
  for (bool force : {false, true}) {
    absl::StatusOr<OutputDirLock> second = PrepareOutputDir("--out", out, force);
    EXPECT_EQ(second.status().code(), absl::StatusCode::kUnavailable) << second.status();
  }
  EXPECT_TRUE(fs::exists(out / "result.json"));
}

}  // namespace
}  // namespace mvbrdf::client
