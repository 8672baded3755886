// Real-time scheduling (SCHED_FIFO) for the threads a request waits on: DDS receive threads and query
// threads.
//
// Why: on a busy 2-core machine a normal (SCHED_OTHER) thread that has run past its slice counts as having
// had its share while the map update's low-priority threads are owed time. Linux's EEVDF scheduler then
// gives the core to the update thread, and nothing takes it back before the next timer tick (4 ms at the
// common HZ=250). A 0.2 ms query answer then takes ~4.2 ms; in a scheduler trace of a kitti00 stream on 2
// cores such stalls made up the round trip's slowest 1% (docs/BENCHMARKS.md). A SCHED_FIFO thread always
// runs before every SCHED_OTHER thread, so the answer is never parked behind the update.
#pragma once

namespace densemap::util {

/// Puts the calling thread in SCHED_FIFO at `priority` (1..99); threads it creates afterwards inherit it
/// (glibc's default). 0 puts it back in SCHED_OTHER, its nice value unchanged (always allowed). Returns
/// false when the kernel refuses: raising needs root, CAP_SYS_NICE or RLIMIT_RTPRIO >= priority (e.g.
/// `ulimit -r 10`, or an `rtprio` line in /etc/security/limits.conf).
bool setRealtimePriority(int priority);

/// The calling thread's SCHED_FIFO priority; 0 when it is not SCHED_FIFO.
int realtimePriority();

/// For a thread that does bulk work (pipeline stages, scan intake, statistics): normal scheduling and the
/// kernel's default slice, whatever the thread that created it had asked for the latency-bound threads.
void useBulkScheduling();

/// How to allow `priority`, for error messages.
const char* realtimePriorityHint();

}  // namespace densemap::util
