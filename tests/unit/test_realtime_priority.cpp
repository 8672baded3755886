// setRealtimePriority: a thread enters SCHED_FIFO, threads it creates inherit it, and 0 returns it to
// SCHED_OTHER with its nice value kept.
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <thread>

#include <gtest/gtest.h>

#include "densemap/util/realtime_priority.h"

namespace densemap::util {
namespace {

int threadNice() { return getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid))); }

TEST(RealtimePriority, IsSetInheritedByNewThreadsAndDroppedKeepingTheNiceValue) {
  // On a thread of its own, so the test runner's thread stays as it is.
  std::thread([] {
    ASSERT_EQ(setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 3), 0);
    if (!setRealtimePriority(7))
      GTEST_SKIP() << "this process may not use SCHED_FIFO (not root, no CAP_SYS_NICE, RLIMIT_RTPRIO < 7)";
    EXPECT_EQ(realtimePriority(), 7);
    int child = -1;
    std::thread([&] { child = realtimePriority(); }).join();
    EXPECT_EQ(child, 7) << "threads created afterwards inherit SCHED_FIFO and its priority";
    EXPECT_TRUE(setRealtimePriority(0));
    EXPECT_EQ(realtimePriority(), 0);
    EXPECT_EQ(threadNice(), 3) << "back in SCHED_OTHER with the nice value it had";
    std::thread([&] { child = realtimePriority(); }).join();
    EXPECT_EQ(child, 0);
  }).join();
}

TEST(RealtimePriority, RejectsPrioritiesOutsideOneToNinetyNine) {
  EXPECT_FALSE(setRealtimePriority(-1));
  EXPECT_FALSE(setRealtimePriority(100));
  EXPECT_EQ(realtimePriority(), 0);
}

}  // namespace
}  // namespace densemap::util
