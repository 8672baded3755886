#include "densemap/util/retain_freed_memory.h"

#include <malloc.h>

namespace densemap::util {

void retainFreedMemory() {
#if defined(__GLIBC__)
  mallopt(M_TRIM_THRESHOLD, 512 << 20);  // return heap top to the kernel only beyond 512 MiB free
  mallopt(M_MMAP_THRESHOLD, 32 << 20);   // glibc's maximum: blocks below 32 MiB come from the heap
#endif
}

void returnFreedMemory() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

}  // namespace densemap::util
