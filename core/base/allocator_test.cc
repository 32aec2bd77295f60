#include "core/base/allocator.h"

#include <malloc.h>

#include <cstring>
#include <memory>

#include "gtest/gtest.h"

namespace mvbrdf::base {
namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#else
constexpr bool kSanitized = false;
#endif

// A freed 8 MiB block stays in the heap (glibc's default maps a block that
// size and unmaps it on free), and the next one reuses it.
TEST(AllocatorTest, KeepsAFreedBlockOfSomeMegabytes) {
  if (kSanitized) GTEST_SKIP() << "AddressSanitizer's allocator ignores mallopt (CMakeLists: a release case)";
  ASSERT_TRUE(KeepFreedMemoryForReuse());
  constexpr size_t kBytes = size_t{8} << 20;
  static_assert(kBytes < kHeapBlockBytes && kBytes < kKeptFreeBytes);
  const struct mallinfo2 before = mallinfo2();
  {
    std::unique_ptr<char[]> block(new char[kBytes]);
    std::memset(block.get(), 1, kBytes);
    const struct mallinfo2 during = mallinfo2();
    EXPECT_EQ(during.hblkhd, before.hblkhd) << "the block was mmapped";
  }
  const struct mallinfo2 after = mallinfo2();
  EXPECT_GE(after.fordblks, before.fordblks + kBytes) << "the freed block went back to the system";
}

}  // namespace
}  // namespace mvbrdf::base
