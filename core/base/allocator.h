// How this process's heap (glibc malloc) treats large freed blocks.
#ifndef MVBRDF_CORE_BASE_ALLOCATOR_H_
#define MVBRDF_CORE_BASE_ALLOCATOR_H_

#include <cstddef>

namespace mvbrdf::base {

// Blocks up to kHeapBlockBytes come from the heap and freed memory up to
// kKeptFreeBytes stays with the process for the next allocation, instead of
// each block of a few MB being mapped, faulted in page by page and unmapped
// again (glibc's defaults: blocks from 128 KiB are mmapped, raised
// dynamically at most to 32 MiB, and the heap's top is trimmed from twice
// that). The fits allocate and free their per-sample arrays at every call
// (tens of thousands of calls per job); on this machine (a VM: each page
// fault is a trap to the hypervisor) the faults took 2/3 of a 1e5-sample
// Phong fit (scripts/bench-peer). Call once, first thing in main(); false
// when glibc refused a setting.
constexpr size_t kHeapBlockBytes = size_t{32} << 20;
constexpr size_t kKeptFreeBytes = size_t{64} << 20;
bool KeepFreedMemoryForReuse();

}  // namespace mvbrdf::base

#endif  // MVBRDF_CORE_BASE_ALLOCATOR_H_
