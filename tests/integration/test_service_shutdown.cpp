// Shutdown accounts for every scan: a robot keeps sending while the server stops; every scan
// the server took from DDS ends mapped, dropped or rejected and its acknowledgement reaches the robot.
// Draining (the default), none is dropped, not even the one waiting for space in a full queue.
#include <atomic>
#include <thread>

#include <gtest/gtest.h>

#include "service_harness.h"

namespace densemap::test {
namespace {

struct ShutdownCounts {
  std::uint64_t sent = 0, received = 0, processed = 0, dropped = 0, rejected = 0, acknowledged = 0;
};

/// Publishes `total` scans as fast as the server takes them, stops the server once it has taken
/// `stop_after` (publishing is asynchronous: a published scan may still be on its way), keeps publishing
/// meanwhile, and counts what each side saw.
ShutdownCounts sendThroughShutdown(int domain, bool drop_on_exit, std::size_t total, std::size_t stop_after) {
  auto o = serverOptions(domain);
  o.pipeline.robot_queue_capacity = 2;  // the intake soon waits for space: the case that matters
  o.drop_on_exit = drop_on_exit;
  ServiceHarness h(o);
  io::LidarSimulatorOptions sim_options;
  sim_options.scans = 8;  // full 64-beam scans: slow enough to queue up
  io::LidarSimulator sim(sim_options);
  const auto scans = readScans(sim, 0, 7);
  std::atomic<std::size_t> published{0};
  std::thread robot([&] {
    for (std::size_t i = 0; i < total; ++i) {
      if (!h.robot->publish("robot-0", i, scans[i % scans.size()])) break;  // no server any more
      published = i + 1;
    }
  });
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  while (h.server->service.statistics().totals().received < stop_after &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(1ms);
  h.server->edge.stop();  // what SIGTERM does in densemap-server
  robot.join();
  ShutdownCounts c;
  c.sent = published;
  const auto totals = h.server->service.statistics().totals();
  c.received = totals.received;
  c.processed = totals.processed;
  c.dropped = totals.dropped;
  c.rejected = totals.rejected;
  // The server waited until the robot confirmed its acknowledgements; the listener may still be storing them.
  c.acknowledged = h.robot->waitForAcks({"robot-0"}, c.received, 10s).total();
  // Scans arrive in order, so the received ones are the first `received`.
  for (std::uint64_t seq = 0; seq < std::min(c.sent, c.received); ++seq) {
    EXPECT_TRUE(h.robot->ack("robot-0", seq).has_value()) << "no acknowledgement for #" << seq;
  }
  return c;
}

TEST(Shutdown, DrainingEveryReceivedScanIsMappedOrRefusedAndAcknowledged) {
  const auto c = sendThroughShutdown(137, false, 60, 3);
  EXPECT_GE(c.received, 3u);
  EXPECT_EQ(c.received, c.processed + c.dropped + c.rejected) << "a received scan has no outcome";
  EXPECT_EQ(c.acknowledged, c.received)
      << "sent " << c.sent << ", in map " << c.processed << ", rejected " << c.rejected;
  EXPECT_EQ(c.dropped, 0u) << "draining drops nothing, not even the scan waiting for queue space";
  EXPECT_GT(c.processed, 0u);
}

TEST(Shutdown, DroppingEveryReceivedScanIsAccountedAndAcknowledged) {
  const auto c = sendThroughShutdown(138, true, 60, 3);
  EXPECT_GE(c.received, 3u);
  EXPECT_EQ(c.received, c.processed + c.dropped + c.rejected) << "a received scan has no outcome";
  EXPECT_EQ(c.acknowledged, c.received) << "sent " << c.sent << ", in map " << c.processed << ", dropped "
                                        << c.dropped << ", rejected " << c.rejected;
}

}  // namespace
}  // namespace densemap::test
