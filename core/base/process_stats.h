// Process-level measurements for reports and benchmarks.
#ifndef MVBRDF_CORE_BASE_PROCESS_STATS_H_
#define MVBRDF_CORE_BASE_PROCESS_STATS_H_

#include <cstdint>

namespace mvbrdf {

// Peak resident set size of this process so far (Linux VmHWM), in bytes; 0
// when unknown.
uint64_t PeakRssBytes();

// How much more memory this process may allocate, as far as the machine and
// its limits tell: the least of the address space left under RLIMIT_AS
// (`ulimit -v`), the cgroup's memory.max less its memory.current, and
// MemAvailable plus SwapFree. `limited_by` (optional) gets which one it was
// ("ulimit -v", "the cgroup's memory.max" or "free memory"). UINT64_MAX when
// nothing is known.
uint64_t AvailableMemoryBytes(const char** limited_by = nullptr);

}  // namespace mvbrdf

#endif  // MVBRDF_CORE_BASE_PROCESS_STATS_H_
