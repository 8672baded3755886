#include "densemap/util/realtime_priority.h"

#include <pthread.h>
#include <sched.h>

#include "densemap/util/scheduler_slice.h"

namespace densemap::util {

bool setRealtimePriority(int priority) {
  if (priority < 0 || priority > 99) return false;
  sched_param param{};
  param.sched_priority = priority;
  return pthread_setschedparam(pthread_self(), priority > 0 ? SCHED_FIFO : SCHED_OTHER, &param) == 0;
}

int realtimePriority() {
  int policy = SCHED_OTHER;
  sched_param param{};
  if (pthread_getschedparam(pthread_self(), &policy, &param) != 0 || policy != SCHED_FIFO) return 0;
  return param.sched_priority;
}

void useBulkScheduling() {
  // Leaving SCHED_FIFO first: the slice can only be set on a SCHED_OTHER thread.
  setRealtimePriority(0);
  requestSchedulerSlice(std::chrono::microseconds(0));
}

const char* realtimePriorityHint() {
  return "run as root, grant CAP_SYS_NICE (setcap cap_sys_nice+ep BINARY) or raise RLIMIT_RTPRIO "
         "(`ulimit -r 10`, or an `rtprio` line in /etc/security/limits.conf)";
}

}  // namespace densemap::util
