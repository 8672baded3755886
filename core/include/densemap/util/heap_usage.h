// What the allocator holds: the bytes live in it and the freed bytes it keeps for reuse.
#pragma once

#include <cstdint>

namespace densemap::util {

struct HeapUsage {
  std::uint64_t in_use_bytes = 0;  ///< allocated and not yet freed (heap and mmap'ed blocks)
  std::uint64_t free_bytes = 0;    ///< freed but still mapped: retainFreedMemory keeps these for reuse
};

/// From glibc's mallinfo2 over every arena (zero elsewhere). It walks the arenas' free lists, so it is for
/// the periodic report, not for a hot path. Resident memory minus in_use is what retention and
/// fragmentation cost, which tells a leak (in_use grows) from a kept high-water mark (free grows).
HeapUsage heapUsage();

}  // namespace densemap::util
