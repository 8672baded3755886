#include "densemap/util/scheduler_slice.h"

#include <sched.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cstdint>

namespace densemap::util {
namespace {
// The kernel's struct sched_attr (uapi linux/sched/types.h, which clashes with glibc's <sched.h>).
struct SchedAttr {
  std::uint32_t size;
  std::uint32_t sched_policy;
  std::uint64_t sched_flags;
  std::int32_t sched_nice;
  std::uint32_t sched_priority;
  std::uint64_t sched_runtime;
  std::uint64_t sched_deadline;
  std::uint64_t sched_period;
  std::uint32_t sched_util_min;
  std::uint32_t sched_util_max;
};
}  // namespace

bool requestSchedulerSlice(std::chrono::microseconds slice) {
  // glibc 2.36 (Debian 12) has no sched_setattr wrapper. Read the attributes first so the policy and
  // nice value stay as they are; only sched_runtime (the slice, for SCHED_OTHER) changes.
  SchedAttr attr{};
  if (syscall(SYS_sched_getattr, 0, &attr, sizeof(attr), 0) != 0) return false;
  if (attr.sched_policy != SCHED_OTHER && attr.sched_policy != SCHED_BATCH) return false;
  attr.size = sizeof(attr);
  attr.sched_flags = 0;
  attr.sched_runtime = static_cast<std::uint64_t>(std::chrono::nanoseconds(slice).count());
  if (syscall(SYS_sched_setattr, 0, &attr, 0) != 0) return false;
  if (slice.count() == 0) return true;
  SchedAttr now{};
  if (syscall(SYS_sched_getattr, 0, &now, sizeof(now), 0) != 0) return false;
  return now.sched_runtime == attr.sched_runtime;
}

}  // namespace densemap::util
