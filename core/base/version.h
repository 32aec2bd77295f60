#ifndef MVBRDF_CORE_BASE_VERSION_H_
#define MVBRDF_CORE_BASE_VERSION_H_

#include <string_view>

namespace mvbrdf {

// mvbrdf's release version, the CMake project version (e.g. "0.1.0").
std::string_view MvbrdfVersion();

// The git commit the binary was built from: 40 hex digits, with "-dirty"
// appended when the working tree had uncommitted changes to tracked files;
// "unknown" when the source was not a git checkout. Taken at build time.
std::string_view GitCommit();

}  // namespace mvbrdf

#endif  // MVBRDF_CORE_BASE_VERSION_H_
