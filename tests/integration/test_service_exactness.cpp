// The served map equals the core's offline map of the same scans, cell for cell, checked through the
// query API (point queries at every cell, map statistics, and a saved .ot file for the octree backend).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>

#include <gtest/gtest.h>
#include <octomap/AbstractOcTree.h>

#include "densemap/io/lidar_simulator.h"
#include "densemap/sources/open_source.h"
#include "service_harness.h"
#include "test_data.h"
#include "test_simulator.h"

namespace densemap::test {
namespace {

TEST(ServiceExactness, SimulatorGridMatchesOfflineMap) {
  auto o = serverOptions(110);
  ServiceHarness h(o);
  const auto scans = simScans(6);
  const auto acks = h.replay(scans);
  ASSERT_EQ(acks.applied, scans.size());
  const auto offline = offlineMap<map::GridMap>(scans, o.map.resolution);
  expectServedEquals(h, *offline);
}

TEST(ServiceExactness, SimulatorOctreeSavesTheOfflineTreeNodeForNode) {
  auto o = serverOptions(111);
  o.map.backend = "octree";
  o.map.resolution = 0.25;
  ServiceHarness h(o);
  const auto scans = simScans(5);
  ASSERT_EQ(h.replay(scans).applied, scans.size());
  const auto offline = offlineMap<map::OctreeMap>(scans, o.map.resolution);
  expectServedEquals(h, *offline);

  const std::string path = (std::filesystem::path(o.map_dir) / "densemap_test_111.ot").string();
  const auto r = h.admin->call(client::saveRequest("densemap_test_111.ot"), 60s);
  ASSERT_EQ(r.status(), msg::STATUS_OK) << r.message();
  std::unique_ptr<octomap::AbstractOcTree> loaded(octomap::AbstractOcTree::read(path));
  ASSERT_NE(loaded, nullptr) << "could not read " << path;
  auto* tree = dynamic_cast<octomap::OcTree*>(loaded.get());
  ASSERT_NE(tree, nullptr);
  std::string why;
  EXPECT_TRUE(map::identicalTrees(*tree, offline->tree(), &why)) << why;
  std::filesystem::remove(path);
}

TEST(ServiceExactness, TwoRobotsWithTheirOwnOriginsMatchTheOfflineMapInServedOrder) {
  auto o = serverOptions(112);
  ServiceHarness h(o);
  auto a = simScans(4);
  auto b = simScans(4);
  for (auto& s : b) s.pose.pretranslate(Eigen::Vector3d(3.0, 25.0, 0.0));  // a second robot elsewhere
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_TRUE(h.robot->publish("robot-a", i, a[i]));
    ASSERT_TRUE(h.robot->publish("robot-b", i, b[i]));
  }
  const auto acks = h.robot->waitForAcks({"robot-a", "robot-b"}, 8, 120s);
  ASSERT_EQ(acks.applied, 8u);
  // The server interleaves robots; replay offline in the order it applied them (its map versions).
  std::map<std::uint64_t, io::Scan> order;
  for (std::size_t i = 0; i < a.size(); ++i) {
    order[h.robot->ack("robot-a", i)->map_version()] = a[i];
    order[h.robot->ack("robot-b", i)->map_version()] = b[i];
  }
  ASSERT_EQ(order.size(), 8u) << "every scan must have its own map version";
  std::vector<io::Scan> applied;
  for (auto& [v, s] : order) applied.push_back(s);
  expectServedEquals(h, *offlineMap<map::GridMap>(applied, o.map.resolution));
}

TEST(ServiceExactness, La3dmStructuredMatchesOfflineMap) {
  DENSEMAP_REQUIRE_DATA("la3dm/sim_structured");
  auto src = sources::openSource(dataDir() + "/la3dm/sim_structured");
  auto o = serverOptions(113);
  o.map.resolution = 0.1;
  ServiceHarness h(o);
  const auto scans = readScans(*src, 0, src->size() - 1);
  ASSERT_EQ(h.replay(scans).applied, scans.size());
  expectServedEquals(h, *offlineMap<map::GridMap>(scans, o.map.resolution));
}

TEST(ServiceExactness, La3dmUnstructuredOctreeMatchesOfflineMap) {
  DENSEMAP_REQUIRE_DATA("la3dm/sim_unstructured");
  auto src = sources::openSource(dataDir() + "/la3dm/sim_unstructured");
  auto o = serverOptions(114);
  o.map.resolution = 0.1;
  o.map.backend = "octree";
  ServiceHarness h(o);
  const auto scans = readScans(*src, 0, src->size() - 1);
  ASSERT_EQ(h.replay(scans).applied, scans.size());
  expectServedEquals(h, *offlineMap<map::OctreeMap>(scans, o.map.resolution));
}

TEST(ServiceExactness, Kitti00FirstScansMatchOfflineMap) {
  DENSEMAP_REQUIRE_DATA("kitti00");
  auto src = sources::openSource(dataDir() + "/kitti00");
  auto o = serverOptions(115);
  ServiceHarness h(o);
  const auto scans = readScans(*src, 0, 4);
  ASSERT_EQ(h.replay(scans).applied, scans.size());
  expectServedEquals(h, *offlineMap<map::GridMap>(scans, o.map.resolution));
}

}  // namespace
}  // namespace densemap::test
