// requestSchedulerSlice: a thread's scheduler slice is set, inherited by threads it creates, and reset.
#include <sys/syscall.h>
#include <unistd.h>

#include <cstdint>
#include <thread>

#include <gtest/gtest.h>

#include "densemap/util/scheduler_slice.h"

namespace densemap::util {
namespace {

using namespace std::chrono_literals;

/// The calling thread's slice as the kernel reports it (sched_getattr's sched_runtime), in ns.
std::uint64_t currentSliceNs() {
  struct {
    std::uint32_t size, policy;
    std::uint64_t flags;
    std::int32_t nice;
    std::uint32_t priority;
    std::uint64_t runtime, deadline, period;
    std::uint32_t util_min, util_max;
  } attr{};
  EXPECT_EQ(syscall(SYS_sched_getattr, 0, &attr, sizeof(attr), 0), 0);
  return attr.runtime;
}

TEST(SchedulerSlice, IsSetInheritedByNewThreadsAndReset) {
  // On a thread of its own, so the test runner's thread keeps its slice.
  std::thread([] {
    if (!requestSchedulerSlice(100us))
      GTEST_SKIP() << "this kernel does not report custom scheduler slices (Linux < 6.12 ignores them)";
    EXPECT_EQ(currentSliceNs(), 100'000u);
    std::uint64_t child = 0;
    std::thread([&] { child = currentSliceNs(); }).join();
    EXPECT_EQ(child, 100'000u) << "threads created afterwards inherit the slice";
    EXPECT_TRUE(requestSchedulerSlice(0us));
    EXPECT_NE(currentSliceNs(), 100'000u) << "0 returns to the kernel's default";
  }).join();
}

}  // namespace
}  // namespace densemap::util
