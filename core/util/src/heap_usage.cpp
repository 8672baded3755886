#include "densemap/util/heap_usage.h"

#include <malloc.h>

namespace densemap::util {

HeapUsage heapUsage() {
  HeapUsage u;
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
  const struct mallinfo2 m = mallinfo2();
  u.in_use_bytes = m.uordblks + m.hblkhd;  // small and large (mmap'ed) allocations still live
  u.free_bytes = m.fordblks;               // free chunks of every arena, fastbins included
#endif
  return u;
}

}  // namespace densemap::util
