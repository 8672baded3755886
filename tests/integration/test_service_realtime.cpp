// --realtime-priority: the server's DDS and query threads run SCHED_FIFO, its map update, scan intake and
// statistics do not, and the service answers as before.
#include <dirent.h>
#include <sched.h>

#include <fstream>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "densemap/util/realtime_priority.h"
#include "service_harness.h"

namespace densemap::test {
namespace {

/// Every thread of this process: name -> scheduling policies seen.
std::multimap<std::string, int> threadPolicies() {
  std::multimap<std::string, int> out;
  DIR* dir = opendir("/proc/self/task");
  if (dir == nullptr) return out;
  while (const dirent* e = readdir(dir)) {
    if (e->d_name[0] == '.') continue;
    std::string name;
    std::getline(std::ifstream(std::string("/proc/self/task/") + e->d_name + "/comm"), name);
    out.emplace(name, sched_getscheduler(std::stoi(e->d_name)));
  }
  closedir(dir);
  return out;
}

TEST(ServiceRealtime, DdsAndQueryThreadsAreRealtimeAndTheMapUpdateIsNot) {
  bool allowed = false;
  std::thread([&] { allowed = util::setRealtimePriority(5); }).join();
  if (!allowed) GTEST_SKIP() << "this process may not use SCHED_FIFO: " << util::realtimePriorityHint();

  auto o = serverOptions(160);
  o.realtime_priority = 5;
  ServiceHarness h(o);
  EXPECT_EQ(util::realtimePriority(), 0) << "the thread that built the server is back to normal";
  const auto scans = simScans(3);
  const auto acks = h.replay(scans);
  EXPECT_EQ(acks.applied, scans.size());

  // Answers as without it: the offline map's probabilities at every 50th end point of the first scan.
  const auto offline = offlineMap<map::GridMap>(scans, o.map.resolution);
  const auto points = asSent(scans[0]).worldPoints();
  msg::QueryRequest rq;
  rq.kind(msg::QUERY_POINTS);
  std::vector<float> expected;
  for (std::size_t i = 0; i < points.size(); i += 50) {
    rq.points().insert(rq.points().end(), {points[i].x(), points[i].y(), points[i].z()});
    geometry::VoxelKey k;
    ASSERT_TRUE(offline->converter().toKey(points[i], k));
    const auto lo = offline->logOdds(k);
    expected.push_back(lo ? probability(*lo) : 0.5f);
  }
  const auto reply = h.query->call(rq, 30s);
  ASSERT_EQ(reply.status(), msg::STATUS_OK) << reply.message();
  ASSERT_EQ(reply.probabilities().size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i)
    EXPECT_FLOAT_EQ(reply.probabilities()[i], expected[i]) << i;

  int fifo_other = 0, query_threads = 0;
  for (const auto& [name, policy] : threadPolicies()) {
    if (name == "dm-query") {
      ++query_threads;
      EXPECT_EQ(policy, SCHED_FIFO) << name;
    } else if (name.rfind("dm-", 0) == 0) {
      EXPECT_NE(policy, SCHED_FIFO) << name << " (bulk work) must not run real-time";
    } else if (policy == SCHED_FIFO) {
      ++fifo_other;  // DDS's receive and event threads
    }
  }
  EXPECT_EQ(query_threads, o.query_threads);
  EXPECT_GT(fifo_other, 0) << "DDS's threads inherit the priority";
}

}  // namespace
}  // namespace densemap::test
