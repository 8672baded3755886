// UpdatePriority: the map update runs at a low priority while its scan is on time, and at normal priority
// (or the late nice value) from the moment the scan is late, also when that moment comes in the middle of
// the update; between scans the team is back at the low priority.
#include <omp.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "densemap/server/update_priority.h"

namespace densemap::server {
namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

/// The nice values of the calling thread and its OpenMP team, lowest and highest.
std::pair<int, int> teamNice() {
  std::vector<int> nice(static_cast<std::size_t>(omp_get_max_threads()), -100);
#pragma omp parallel
  nice[static_cast<std::size_t>(omp_get_thread_num())] =
      getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)));
  nice.erase(std::remove(nice.begin(), nice.end(), -100), nice.end());
  return {*std::min_element(nice.begin(), nice.end()), *std::max_element(nice.begin(), nice.end())};
}

class UpdatePriorityTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!UpdatePriority::canRaisePriority())
      GTEST_SKIP() << "this process may not raise a thread's priority back (not root, no CAP_SYS_NICE, "
                      "RLIMIT_NICE < 20): UpdatePriority then only lowers it, which these tests cannot undo";
    omp_set_num_threads(2);  // a team with a worker thread even on one core
  }
  void TearDown() override {
#pragma omp parallel
    setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 0);
  }
};

TEST_F(UpdatePriorityTest, AnOnTimeScanRunsAtTheLowPriorityOnEveryTeamThread) {
  UpdatePriority priority({19, 100ms});
  std::pair<int, int> inside{};
  priority.run(Clock::now() + 10s, [&] { inside = teamNice(); });
  EXPECT_EQ(inside.first, 19);
  EXPECT_EQ(inside.second, 19);
  EXPECT_EQ(priority.promotions(), 0u);
}

TEST_F(UpdatePriorityTest, ALateScanRunsAtNormalPriority) {
  UpdatePriority priority({19, 100ms});
  priority.run(Clock::now() + 10s, [] {});  // leaves the team at nice 19
  std::pair<int, int> inside{};
  priority.run(Clock::now() - 1ms, [&] { inside = teamNice(); });
  EXPECT_EQ(inside.first, 0);
  EXPECT_EQ(inside.second, 0);
  EXPECT_EQ(priority.promotions(), 1u);
}

TEST_F(UpdatePriorityTest, ALateScanRunsAtTheLateNiceValue) {
  if (!UpdatePriority::canRaisePriority(-5)) GTEST_SKIP() << "this process may not go below nice 0";
  UpdatePriority priority({19, 100ms, -5});
  std::pair<int, int> inside{};
  priority.run(Clock::now() - 1ms, [&] { inside = teamNice(); });
  EXPECT_EQ(inside.first, -5);
  EXPECT_EQ(inside.second, -5);
  EXPECT_EQ(priority.promotions(), 1u);
}

TEST_F(UpdatePriorityTest, BetweenScansTheTeamIsBackAtTheLowPriority) {
  // The OpenMP workers spin after a parallel region: at a late scan's priority they would compete with
  // the queries until the next scan.
  UpdatePriority priority({19, 100ms});
  priority.run(Clock::now() - 1ms, [] {});
  const auto between = teamNice();
  EXPECT_EQ(between.first, 19);
  EXPECT_EQ(between.second, 19);
}

TEST_F(UpdatePriorityTest, AnUpdateThatBecomesLateIsRaisedWhileItRuns) {
  UpdatePriority priority({19, 100ms});
  const auto late_at = Clock::now() + 200ms;
  std::pair<int, int> before{}, after{};
  Clock::time_point raised_at{};
  priority.run(late_at, [&] {
    before = teamNice();
    const auto give_up = Clock::now() + 5s;
    while (Clock::now() < give_up) {
      after = teamNice();
      if (after.second == 0) {
        raised_at = Clock::now();
        break;
      }
      std::this_thread::sleep_for(5ms);
    }
  });
  EXPECT_EQ(before.second, 19) << "the scan starts on time";
  EXPECT_EQ(after.first, 0);
  EXPECT_EQ(after.second, 0) << "raised within 5 s";
  EXPECT_GE(raised_at, late_at) << "not before the scan is late";
  EXPECT_EQ(priority.promotions(), 1u);
}

TEST_F(UpdatePriorityTest, LowNiceZeroLeavesThePriorityAlone) {
  UpdatePriority priority({0, 100ms});
  std::pair<int, int> inside{};
  priority.run(Clock::now() + 10s, [&] { inside = teamNice(); });
  EXPECT_EQ(inside.second, 0);
}

}  // namespace
}  // namespace densemap::server
