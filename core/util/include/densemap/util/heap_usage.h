// What the allocator holds: the bytes live in it and the freed bytes it keeps for reuse.
#pragma once

#include <cstdint>

namespace densemap::util {

struct HeapUsage {
  std::uint64_t in_use_bytes = 0;  ///< allocated and not yet freed (heap and mmap'ed blocks)
  /// Freed, held by the allocator for reuse. Resident unless returnFreedMemory gave the pages back (it
  /// keeps the chunks, so they still count here): then resident minus in_use is the better figure.
  std::uint64_t free_bytes = 0;
};

/// From glibc's mallinfo2 over every arena (zero elsewhere). It walks the arenas' free lists, so it is for
/// the periodic report, not for a hot path. It tells a leak (in_use grows) from a kept high-water mark
/// (in_use flat, resident memory above it).
HeapUsage heapUsage();

}  // namespace densemap::util
