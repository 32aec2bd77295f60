// Helpers shared by the libFuzzer targets: a per-process scratch directory
// (the loaders under test take paths, so a target writes its input to a file).
#ifndef MVBRDF_TESTS_FUZZ_FUZZ_UTIL_H_
#define MVBRDF_TESTS_FUZZ_FUZZ_UTIL_H_

#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "absl/status/status.h"

namespace mvbrdf::fuzz {

// A directory private to this process, under $TMPDIR (else /dev/shm, else
// /tmp), created on first use and removed at exit. Fuzz workers (-jobs,
// -fork) are separate processes and get separate directories.
const std::filesystem::path& ScratchDir();

// Writes `size` bytes to `file` (truncating); aborts on failure, which is a
// broken environment, not a finding.
void WriteBytes(const std::filesystem::path& file, const uint8_t* data, size_t size);

// Prints `status` to stderr when MVBRDF_FUZZ_VERBOSE is set (to see how far a
// seed gets: `MVBRDF_FUZZ_VERBOSE=1 ./scene_json_fuzz seed.json`).
void Trace(const char* what, const absl::Status& status);

// Aborts with `message` (a finding: libFuzzer saves the input) unless `ok`.
void Require(bool ok, const char* message);

}  // namespace mvbrdf::fuzz

#endif  // MVBRDF_TESTS_FUZZ_FUZZ_UTIL_H_
