#include "core/base/allocator.h"

#include <malloc.h>

#include <cstdlib>
#include <cstring>

namespace mvbrdf::base {

bool KeepFreedMemoryForReuse() {
  const char* defaults = std::getenv("MVBRDF_DEFAULT_MALLOC");
  if (defaults != nullptr && std::strcmp(defaults, "1") == 0) return false;
  // Setting either turns glibc's dynamic threshold off; both are set.
  const bool mmap_ok = mallopt(M_MMAP_THRESHOLD, static_cast<int>(kHeapBlockBytes)) == 1;
  const bool trim_ok = mallopt(M_TRIM_THRESHOLD, static_cast<int>(kKeptFreeBytes)) == 1;
  return mmap_ok && trim_ok;
}

}  // namespace mvbrdf::base
