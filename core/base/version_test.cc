#include "core/base/version.h"

#include <string>

#include "gtest/gtest.h"

namespace mvbrdf {
namespace {

TEST(Version, IsTheProjectVersion) { EXPECT_EQ(MvbrdfVersion(), MVBRDF_PROJECT_VERSION); }

// The tests run from a git checkout (CI clones one), so the commit is known:
// 40 lowercase hex digits, optionally "-dirty".
TEST(Version, GitCommitIsAHash) {
  std::string commit(GitCommit());
  const std::string dirty = "-dirty";
  if (commit.size() > dirty.size() && commit.compare(commit.size() - dirty.size(), dirty.size(), dirty) == 0) {
    commit.resize(commit.size() - dirty.size());
  }
  ASSERT_EQ(commit.size(), 40u) << GitCommit();
  EXPECT_EQ(commit.find_first_not_of("0123456789abcdef"), std::string::npos) << GitCommit();
}

}  // namespace
}  // namespace mvbrdf
