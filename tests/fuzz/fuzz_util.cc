#include "tests/fuzz/fuzz_util.h"

#include <stdlib.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <system_error>

namespace mvbrdf::fuzz {
namespace {

std::filesystem::path* scratch = nullptr;

void RemoveScratch() {
  if (scratch == nullptr) return;
  std::error_code ec;
  std::filesystem::remove_all(*scratch, ec);
}

std::filesystem::path BaseDir() {
  if (const char* tmp = std::getenv("TMPDIR"); tmp != nullptr && *tmp != '\0') return tmp;
  std::error_code ec;
  if (std::filesystem::is_directory("/dev/shm", ec) && ::access("/dev/shm", W_OK) == 0) return "/dev/shm";
  return "/tmp";
}

}  // namespace

const std::filesystem::path& ScratchDir() {
  if (scratch == nullptr) {
    std::string tmpl = (BaseDir() / ("mvbrdf_fuzz_" + std::to_string(::getpid()) + "_XXXXXX")).string();
    Require(::mkdtemp(tmpl.data()) != nullptr, "fuzz: cannot create the scratch directory");
    scratch = new std::filesystem::path(tmpl);
    std::atexit(RemoveScratch);
  }
  return *scratch;
}

void WriteBytes(const std::filesystem::path& file, const uint8_t* data, size_t size) {
  std::FILE* f = std::fopen(file.c_str(), "wb");
  Require(f != nullptr, "fuzz: cannot open a scratch file for writing");
  Require(size == 0 || std::fwrite(data, 1, size, f) == size, "fuzz: cannot write a scratch file");
  Require(std::fclose(f) == 0, "fuzz: cannot close a scratch file");
}

void Trace(const char* what, const absl::Status& status) {
  static const bool verbose = std::getenv("MVBRDF_FUZZ_VERBOSE") != nullptr;
  if (verbose) std::fprintf(stderr, "%s: %s\n", what, status.ToString().c_str());
}

void Require(bool ok, const char* message) {
  if (ok) return;
  std::fprintf(stderr, "%s\n", message);
  std::abort();
}

}  // namespace mvbrdf::fuzz
