// A fresh directory per test under the GoogleTest temp dir, removed at exit.
#ifndef MVBRDF_SERVER_STORE_TEST_DIR_H_
#define MVBRDF_SERVER_STORE_TEST_DIR_H_

#include <filesystem>
#include <string>
#include <system_error>

#include <gtest/gtest.h>
#include <unistd.h>

namespace mvbrdf::store {

class TestDir {
 public:
  TestDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::path(::testing::TempDir()) /
            (std::string("mvbrdf_store_") + std::to_string(::getpid()) + "_" + info->test_suite_name() + "_" +
             info->name());
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TestDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  TestDir(const TestDir&) = delete;
  TestDir& operator=(const TestDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path db() const { return path_ / "store.db"; }

 private:
  std::filesystem::path path_;
};

}  // namespace mvbrdf::store

#endif  // MVBRDF_SERVER_STORE_TEST_DIR_H_
