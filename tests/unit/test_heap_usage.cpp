// util::heapUsage: what the server reports as live heap and as freed memory kept for reuse.
#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "densemap/util/heap_usage.h"
#include "densemap/util/retain_freed_memory.h"

namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kOwnAllocator = true;  // AddressSanitizer's allocator, not glibc's arenas
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kOwnAllocator = true;
#else
constexpr bool kOwnAllocator = false;
#endif
#else
constexpr bool kOwnAllocator = false;
#endif

constexpr std::uint64_t kMiB = std::uint64_t{1} << 20;

TEST(HeapUsage, ALargeBlockCountsAsInUseUntilFreed) {
  if (kOwnAllocator) GTEST_SKIP() << "built with AddressSanitizer: mallinfo2 does not see its allocator";
  const auto before = densemap::util::heapUsage();
  auto block = std::make_unique<char[]>(64 * kMiB);
  block[0] = 1;
  const auto holding = densemap::util::heapUsage();
  EXPECT_GE(holding.in_use_bytes, before.in_use_bytes + 64 * kMiB);
  block.reset();
  const auto after = densemap::util::heapUsage();
  EXPECT_LE(after.in_use_bytes + 64 * kMiB, holding.in_use_bytes);
}

TEST(HeapUsage, FreedSmallBlocksAreKeptAsFreeWhenRetained) {
  if (kOwnAllocator) GTEST_SKIP() << "built with AddressSanitizer: mallinfo2 does not see its allocator";
  densemap::util::retainFreedMemory();
  const auto before = densemap::util::heapUsage();
  std::vector<std::unique_ptr<char[]>> blocks;
  for (int i = 0; i < 20000; ++i) blocks.push_back(std::make_unique<char[]>(1000));
  const auto holding = densemap::util::heapUsage();
  EXPECT_GE(holding.in_use_bytes, before.in_use_bytes + 20000 * 1000);
  blocks.clear();
  blocks.shrink_to_fit();
  const auto after = densemap::util::heapUsage();
  // Given back to the allocator, not to the kernel: live bytes fall, kept bytes rise by as much.
  EXPECT_LE(after.in_use_bytes + 20000 * 1000, holding.in_use_bytes);
  // The blocks may first fill what was free before (static initialisers leave some), so the kept bytes
  // reach the freed total, not that total on top of the earlier free bytes.
  EXPECT_GE(after.free_bytes, std::size_t{20000} * 1000);
  EXPECT_GE(after.free_bytes, before.free_bytes);
  densemap::util::returnFreedMemory();
  EXPECT_LT(densemap::util::heapUsage().free_bytes, after.free_bytes);
}

}  // namespace
