// `mvbrdf --version` / `mvbrdf version`: mvbrdf's version and git commit
// (core/base/version.h) and the versions of the libraries that shape its
// results and its service: gRPC, Protobuf, OpenCV, Ceres, SQLite (the
// linked library's own version where it can tell, else the headers').
#include <ceres/version.h>
#include <google/protobuf/stubs/common.h>
#include <grpcpp/grpcpp.h>
#include <sqlite3.h>

#include <cstdio>
#include <opencv2/core/utility.hpp>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/flags.h"
#include "core/base/version.h"

namespace mvbrdf::client {

std::string VersionText() {
  std::string out = absl::StrCat("mvbrdf ", std::string(MvbrdfVersion()), " (git ", std::string(GitCommit()), ")\n");
  absl::StrAppend(&out, "  gRPC ", grpc::Version(), "\n");
  absl::StrAppend(&out, "  Protobuf ", google::protobuf::internal::VersionString(GOOGLE_PROTOBUF_VERSION), "\n");
  absl::StrAppend(&out, "  OpenCV ", cv::getVersionString(), "\n");
  absl::StrAppend(&out, "  Ceres ", CERES_VERSION_STRING, "\n");
  absl::StrAppend(&out, "  SQLite ", sqlite3_libversion(), "\n");
  return out;
}

int RunVersion(const std::vector<std::string>& args) {
  FlagParser flags("version",
                   "Prints mvbrdf's version and the git commit it was built from (\"-dirty\": with uncommitted\n"
                   "changes), then the versions of gRPC, Protobuf, OpenCV, Ceres and SQLite it runs with.");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf version: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  std::fputs(VersionText().c_str(), stdout);
  return kExitOk;
}

}  // namespace mvbrdf::client
