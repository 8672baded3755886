// Keeps memory that the process frees for reuse instead of returning it to the kernel.
#pragma once

namespace densemap::util {

/// Every scan allocates and frees a few MB (octree nodes pruned and created, point buffers); with glibc's
/// defaults the freed top of the heap is trimmed and large blocks are unmapped, so the next scan faults the
/// same pages in again (~850 page faults per KITTI scan, about 2 ms at 0.4 m on our 2-core VM). Raising the
/// trim and mmap thresholds keeps that memory mapped. Programs call it once at start-up; it changes only
/// when memory goes back to the kernel, never how much the process can allocate.
void retainFreedMemory();

/// Gives the freed memory of every allocator arena back to the kernel now (glibc's malloc_trim). For the
/// rare large request (a query of a million points) whose peak retainFreedMemory would otherwise keep.
void returnFreedMemory();

}  // namespace densemap::util
