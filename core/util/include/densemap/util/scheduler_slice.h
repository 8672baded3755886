// Latency hints for the Linux scheduler: a short time slice for threads that answer requests.
#pragma once

#include <chrono>

namespace densemap::util {

/// Asks the scheduler to give the calling thread time slices of `slice` (0: the kernel's default, ~0.7 ms
/// times 1 + log2(cores)). Threads created afterwards inherit it. On Linux >= 6.12 (EEVDF with custom
/// slices) a waking thread with a shorter slice than the running one preempts it at once instead of
/// waiting for the running thread's slice to end. On a 2-core machine busy with a scan update that wait
/// is ~1.4 ms per thread hand-over, and a query round trip has four of them (client write, server
/// receive, reply write, client receive). Older kernels ignore the request. No privilege is needed.
/// Returns true when the kernel reports the slice in effect afterwards.
bool requestSchedulerSlice(std::chrono::microseconds slice);

}  // namespace densemap::util
