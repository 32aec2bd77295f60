#include "core/base/process_stats.h"

#include <sys/resource.h>

#include <cstdint>
#include <fstream>
#include <limits>
#include <string>

namespace mvbrdf {

uint64_t PeakRssBytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stoull(line.substr(6)) * 1024;  // "VmHWM:   1234 kB"
  }
  return 0;
}

namespace {

// The value of "Key:   1234 kB" in a /proc file, in bytes; 0 when absent.
uint64_t ProcKib(const char* file, const std::string& key) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key, 0) == 0) {
      try {
        return std::stoull(line.substr(key.size())) * 1024;
      } catch (...) {
        return 0;
      }
    }
  }
  return 0;
}

// A cgroup v2 file holding one number ("max": none), UINT64_MAX when absent.
uint64_t CgroupNumber(const char* file) {
  std::ifstream in(file);
  std::string word;
  if (!(in >> word) || word == "max") return std::numeric_limits<uint64_t>::max();
  try {
    return std::stoull(word);
  } catch (...) {
    return std::numeric_limits<uint64_t>::max();
  }
}

}  // namespace

uint64_t AvailableMemoryBytes(const char** limited_by) {
  uint64_t best = std::numeric_limits<uint64_t>::max();
  const char* why = nullptr;
  const auto consider = [&](uint64_t bytes, const char* what) {
    if (bytes < best) {
      best = bytes;
      why = what;
    }
  };
  rlimit as{};
  if (getrlimit(RLIMIT_AS, &as) == 0 && as.rlim_cur != RLIM_INFINITY) {
    const uint64_t used = ProcKib("/proc/self/status", "VmSize:");
    consider(as.rlim_cur > used ? as.rlim_cur - used : 0, "ulimit -v");
  }
  const uint64_t cgroup_max = CgroupNumber("/sys/fs/cgroup/memory.max");
  if (cgroup_max != std::numeric_limits<uint64_t>::max()) {
    const uint64_t current = CgroupNumber("/sys/fs/cgroup/memory.current");
    if (current != std::numeric_limits<uint64_t>::max()) {
      consider(cgroup_max > current ? cgroup_max - current : 0, "the cgroup's memory.max");
    }
  }
  const uint64_t available = ProcKib("/proc/meminfo", "MemAvailable:");
  if (available > 0) consider(available + ProcKib("/proc/meminfo", "SwapFree:"), "free memory");
  if (limited_by != nullptr) *limited_by = why;
  return best;
}

}  // namespace mvbrdf
