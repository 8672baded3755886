// The densify stage (Ch. 4) in the service: scans from 16-beam LiDARs are re-sampled to 64 beams before
// the occupancy update; the served map is exactly the offline map of the same densified scans.
#include <gtest/gtest.h>

#include <filesystem>

#include "densemap/densify/iln_upsampler.h"
#include "densemap/densify/range_upsampler.h"
#include "densemap/server/densify_stage.h"
#include "service_harness.h"

namespace densemap::test {
namespace {

std::vector<io::Scan> sixteenBeamScans(int n) {
  io::LidarSimulator sim(smallSimulator(n, 16, 512));
  return readScans(sim, 0, static_cast<std::size_t>(n - 1));
}

/// What the stage does to a scan, done offline with the core's functions.
io::Scan densified(io::Scan scan, densify::RangeUpsampler& up, int rows) {
  const auto out = server::densifiedGeometry(*scan.lidar, rows, 0);
  scan.points = densify::toPoints(up.upsample(densify::project(scan.sensorPoints(), *scan.lidar), out));
  scan.lidar = out;
  return scan;
}

TEST(ServiceDensify, SixteenBeamScansAreDensifiedBeforeTheMap) {
  auto o = serverOptions(152);
  o.densify.method = "bilinear";
  o.densify.input_rows = 16;
  ServiceHarness h(o);
  const auto scans = sixteenBeamScans(3);
  const auto acks = h.replay(scans);
  ASSERT_EQ(acks.applied, scans.size());
  densify::BilinearUpsampler bilinear;
  std::vector<io::Scan> dense;
  std::size_t raw_points = 0, dense_points = 0;
  for (const auto& s : scans) {
    dense.push_back(densified(s, bilinear, 64));
    raw_points += s.points.size();
    dense_points += dense.back().points.size();
  }
  EXPECT_GT(dense_points, 3 * raw_points);
  const auto expected = offlineMap<map::GridMap>(dense, o.map.resolution);
  expectServedEquals(h, *expected);
  // Denser scans observe more of the scene than the raw 16 beams.
  EXPECT_GT(expected->knownCells(), offlineMap<map::GridMap>(scans, o.map.resolution)->knownCells());
  const auto stats = h.server->statistics();
  EXPECT_EQ(stats.stages()[0].name(), "densify");
  EXPECT_EQ(stats.stages()[0].processed(), scans.size());
}

TEST(ServiceDensify, OnlyTheSelectedRobotsAreDensified) {
  auto o = serverOptions(153);
  o.densify.method = "bilinear";
  o.densify.robots = {"sparse-robot"};
  ServiceHarness h(o);
  const auto sparse = sixteenBeamScans(2);
  const auto full = simScans(2);
  ASSERT_EQ(h.replay(full, "dense-robot").applied, full.size());
  ASSERT_EQ(h.replay(sparse, "sparse-robot").applied, sparse.size());
  densify::BilinearUpsampler bilinear;
  std::vector<io::Scan> expected_scans = full;
  for (const auto& s : sparse) expected_scans.push_back(densified(s, bilinear, 64));
  expectServedEquals(h, *offlineMap<map::GridMap>(expected_scans, o.map.resolution));
  // Every scan passes the stage; its latency counts only the ones it densified.
  const server::ServiceStatistics stats = h.server->service.statistics();
  ASSERT_EQ(stats.stages[0].name, "densify");
  EXPECT_EQ(stats.stages[0].processed, full.size() + sparse.size());
  EXPECT_EQ(stats.stages[0].latency.count, sparse.size());
}

TEST(ServiceDensify, TheShippedIlnModelDensifiesInTheService) {
  auto o = serverOptions(154);
  o.densify.method = "iln";  // the shipped weights, found without configuration
  ServiceHarness h(o);
  const auto scans = sixteenBeamScans(2);
  ASSERT_EQ(h.replay(scans).applied, scans.size());
  const auto served = h.stats();
  ASSERT_EQ(served.status(), msg::STATUS_OK);
  const auto raw = offlineMap<map::GridMap>(scans, o.map.resolution);
  EXPECT_GT(served.stats().known_cells(), raw->knownCells());
}

}  // namespace
}  // namespace densemap::test
