#include "core/base/allocator.h"

#include <malloc.h>

namespace mvbrdf::base {

bool KeepFreedMemoryForReuse() {
  // Setting either turns glibc's dynamic threshold off; both are set.
  const bool mmap_ok = mallopt(M_MMAP_THRESHOLD, static_cast<int>(kHeapBlockBytes)) == 1;
  const bool trim_ok = mallopt(M_TRIM_THRESHOLD, static_cast<int>(kKeptFreeBytes)) == 1;
  return mmap_ok && trim_ok;
}

}  // namespace mvbrdf::base
