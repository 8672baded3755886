// Queries answered while scans stream in see whole scans only: every reply equals the offline map after
// exactly as many scans as the map version it reports.
#include <atomic>
#include <set>
#include <thread>

#include <gtest/gtest.h>

#include "service_harness.h"

namespace densemap::test {
namespace {

TEST(ServiceConsistency, QueriesDuringStreamingSeeWholeScansOnly) {
  auto o = serverOptions(120);
  ServiceHarness h(o);
  const auto scans = simScans(8);
  // Probe cells: a spread of the final map's cells, so most scans change some of them.
  const auto final_map = offlineMap<map::GridMap>(scans, o.map.resolution);
  std::vector<geometry::Vec3f> probes;
  std::size_t i = 0;
  final_map->forEachCell([&](const geometry::VoxelKey& k, float) {
    if (i++ % 97 == 0) probes.push_back(final_map->converter().toCoord(k));
  });
  ASSERT_GT(probes.size(), 1000u);
  // Expected answers after v scans, v = 0..8.
  std::vector<std::vector<float>> expected;
  {
    map::GridMap m(o.map.resolution);
    update::UpdateEngine engine;
    for (std::size_t v = 0; v <= scans.size(); ++v) {
      if (v > 0) {
        const io::Scan s = asSent(scans[v - 1]);
        engine.insert(m, s.worldPoints(), s.origin());
      }
      std::vector<float> p;
      for (const auto& q : probes) {
        geometry::VoxelKey k;
        m.converter().toKey(q, k);
        const auto lo = m.logOdds(k);
        p.push_back(lo ? probability(*lo) : 0.5f);
      }
      expected.push_back(std::move(p));
    }
  }
  msg::QueryRequest rq;
  rq.kind(msg::QUERY_POINTS);
  for (const auto& q : probes) rq.points().insert(rq.points().end(), {q.x(), q.y(), q.z()});

  std::atomic<bool> streaming{true};
  std::atomic<std::size_t> replies{0}, inconsistent{0};
  std::mutex seen_mutex;
  std::set<std::uint64_t> versions_seen;
  std::vector<std::thread> clients;
  for (int c = 0; c < 2; ++c) {
    clients.emplace_back([&, c] {
      client::QueryClient qc(*h.node, "consistency-" + std::to_string(c));
      if (!qc.waitForServer(20s)) return;
      while (streaming) {
        const auto r = qc.call(rq, 30s);
        if (r.status() != msg::STATUS_OK || r.map_version() > scans.size() ||
            r.probabilities() != expected[r.map_version()]) {
          ++inconsistent;
        }
        ++replies;
        std::lock_guard lock(seen_mutex);
        versions_seen.insert(r.map_version());
      }
    });
  }
  std::this_thread::sleep_for(300ms);  // clients discovered and querying the empty map
  for (std::size_t s = 0; s < scans.size(); ++s) {
    ASSERT_TRUE(h.robot->publish("robot-0", s, scans[s]));
    std::this_thread::sleep_for(50ms);
  }
  const auto acks = h.robot->waitForAcks({"robot-0"}, scans.size(), 120s);
  std::this_thread::sleep_for(100ms);
  streaming = false;
  for (auto& t : clients) t.join();
  EXPECT_EQ(acks.applied, scans.size());
  EXPECT_EQ(inconsistent.load(), 0u) << "of " << replies.load() << " replies";
  // The test only means something if queries really interleaved with the updates.
  EXPECT_GE(versions_seen.size(), 4u) << "queries saw too few map versions to test consistency";
  EXPECT_TRUE(versions_seen.count(scans.size())) << "no query saw the final map";
}

}  // namespace
}  // namespace densemap::test
