// Process-level measurements for reports and benchmarks.
#ifndef MVBRDF_CORE_BASE_PROCESS_STATS_H_
#define MVBRDF_CORE_BASE_PROCESS_STATS_H_

#include <cstdint>

namespace mvbrdf {

// Peak resident set size of this process so far (Linux VmHWM), in bytes; 0
// when unknown.
uint64_t PeakRssBytes();

}  // namespace mvbrdf

#endif  // MVBRDF_CORE_BASE_PROCESS_STATS_H_
