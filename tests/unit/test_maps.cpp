// Map backends: OctoMap's update rule (add then clamp, early abort when clamped), agreement between the grid
// and the octree, bad input rejected without touching the map, and OctoMap file round trips.
#include <cmath>
#include <filesystem>
#include <limits>
#include <random>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include "densemap/io/lidar_simulator.h"
#include "densemap/map/grid_map.h"
#include "densemap/map/octree_map.h"
#include "densemap/update/update_engine.h"
#include "test_simulator.h"

namespace densemap::map {
namespace {

using geometry::Vec3f;

TEST(Maps, CellUpdateFollowsOctomap) {
  // Random sequences of single hit / miss updates on one cell, against OctoMap's updateNode.
  octomap::OcTree tree(0.1);
  const LogOdds lo{OccupancyParams{}};
  std::mt19937 rng(1);
  for (int seq = 0; seq < 200; ++seq) {
    tree.clear();
    const octomap::OcTreeKey key(100, 200, 300);
    float v = 0.0f;
    for (int i = 0; i < 40; ++i) {
      const bool hit = (rng() % 3) == 0;
      tree.updateNode(key, hit, false);
      v = applyCellUpdate(v, hit ? 0 : 1, hit ? 1 : 0, lo);
      ASSERT_EQ(tree.search(key)->getLogOdds(), v) << "sequence " << seq << " step " << i;
    }
  }
}

TEST(Maps, CountingAppliesFreeThenHitClamped) {
  const LogOdds lo{OccupancyParams{}};
  // 3 misses and 1 hit in one scan from unknown: 3 * l_free, clamp, then + l_occ.
  const float expected_free = std::max(lo.min, 3.0f * lo.miss);
  EXPECT_EQ(applyCellUpdate(0.0f, 3, 1, lo), std::min(lo.max, expected_free + lo.hit));
  // Fully free: many misses clamp at the bound, whatever their number.
  EXPECT_EQ(applyCellUpdate(0.0f, 50, 0, lo), lo.min);
  EXPECT_EQ(applyCellUpdate(0.0f, 5000, 0, lo), lo.min);
  EXPECT_TRUE(isNoOpUpdate(true, lo.min, 7, 0, lo));
  EXPECT_FALSE(isNoOpUpdate(true, lo.min, 7, 1, lo));
  EXPECT_FALSE(isNoOpUpdate(false, 0.0f, 1, 0, lo));
}

struct SimMaps : ::testing::Test {
  io::LidarSimulator sim{test::smallSimulator(6)};

  /// Maps the first `scans` simulated scans into both maps, one engine for both; false if any insert
  /// was refused.
  bool mapBoth(OccupancyMap& a, OccupancyMap& b, std::size_t scans) {
    update::UpdateEngine engine;
    bool ok = true;
    for (std::size_t i = 0; i < scans; ++i) {
      const io::Scan s = sim.read(i);
      ok = engine.insert(a, s.worldPoints(), s.origin()).has_value() && ok;
      ok = engine.insert(b, s.worldPoints(), s.origin()).has_value() && ok;
    }
    return ok;
  }
};

TEST_F(SimMaps, GridAndOctreeHoldTheSameCells) {
  GridMap grid(0.3);
  OctreeMap octree(0.3);
  ASSERT_TRUE(mapBoth(grid, octree, sim.size()));
  EXPECT_EQ(grid.knownCells(), octree.knownCells());
  std::size_t compared = 0;
  grid.forEachCell([&](const geometry::VoxelKey& k, float v) {
    const auto o = octree.logOdds(k);
    ASSERT_TRUE(o.has_value());
    EXPECT_EQ(*o, v);
    ++compared;
  });
  EXPECT_GT(compared, 10000u);
}

TEST_F(SimMaps, BatchLookupsEqualSingleLookupsOnBothBackends) {
  GridMap grid(0.2);
  OctreeMap octree(0.2);
  ASSERT_TRUE(mapBoth(grid, octree, 3));
  // Random cells around the sensor (known and unknown), more than one batch chunk, in random order.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-12.0f, 12.0f), uz(-2.0f, 2.0f);
  std::vector<geometry::VoxelKey> keys;
  while (keys.size() < 5000) {
    geometry::VoxelKey k;
    if (grid.converter().toKey(Vec3f(u(rng), u(rng), uz(rng)), k)) keys.push_back(k);
  }
  for (const OccupancyMap* m :
       {static_cast<const OccupancyMap*>(&grid), static_cast<const OccupancyMap*>(&octree)}) {
    std::vector<float> out(keys.size(), 123.0f);
    m->logOddsMany(keys, out);
    std::size_t known = 0;
    for (std::size_t i = 0; i < keys.size(); ++i) {
      const auto v = m->logOdds(keys[i]);
      if (v) {
        ++known;
        ASSERT_EQ(out[i], *v) << m->backendName() << " key " << i;
      } else {
        ASSERT_TRUE(std::isnan(out[i])) << m->backendName() << " key " << i;
      }
    }
    EXPECT_GT(known, 500u) << m->backendName();
    EXPECT_LT(known, keys.size()) << m->backendName();
  }
}

TEST_F(SimMaps, PublishedApplyEqualsInPlaceApplyAndChangesNothingBeforePublishing) {
  GridMap in_place(0.2), published(0.2);
  update::UpdateEngine a, b;
  for (std::size_t i = 0; i < sim.size(); ++i) {
    const io::Scan s = sim.read(i);
    ASSERT_TRUE(a.insert(in_place, s.worldPoints(), s.origin()));
    const std::size_t cells_before = published.knownCells();
    bool published_once = false;
    ASSERT_TRUE(b.insert(published, s.worldPoints(), s.origin(), [&](const std::function<void()>& commit) {
      // Until the commit, readers see the previous scan's map.
      EXPECT_EQ(published.knownCells(), cells_before);
      commit();
      published_once = true;
    }));
    EXPECT_TRUE(published_once);
    std::string why;
    ASSERT_TRUE(in_place.identical(published, &why)) << "after scan " << i << ": " << why;
  }
}

TEST_F(SimMaps, EraseBoxForgetsExactlyTheBoxOnBothBackends) {
  GridMap grid(0.3);
  OctreeMap octree(0.3);
  mapBoth(grid, octree, 3);
  geometry::VoxelKey lo, hi;
  grid.converter().toKey(geometry::Vec3f(-12, -4, -1), lo);
  grid.converter().toKey(geometry::Vec3f(-6, 4, 2), hi);
  std::size_t inside = 0;
  grid.forEachCellInBox(lo, hi, [&](const geometry::VoxelKey&, float) { ++inside; });
  ASSERT_GT(inside, 100u);
  const std::size_t before = grid.knownCells();
  EXPECT_EQ(grid.eraseBox(lo, hi), inside);
  EXPECT_EQ(octree.eraseBox(lo, hi), inside);
  EXPECT_EQ(grid.knownCells(), before - inside);
  EXPECT_EQ(octree.knownCells(), before - inside);
  grid.forEachCell([&](const geometry::VoxelKey& k, float v) {
    EXPECT_FALSE(OccupancyMap::inBox(k, lo, hi));
    EXPECT_EQ(octree.logOdds(k), v);
  });
}

TEST_F(SimMaps, IdenticalDetectsASingleDifference) {
  GridMap a(0.3), b(0.3);
  update::UpdateEngine engine;
  const io::Scan s = sim.read(0);
  engine.insert(a, s.worldPoints(), s.origin());
  engine.insert(b, s.worldPoints(), s.origin());
  std::string why;
  ASSERT_TRUE(a.identical(b, &why)) << why;
  std::vector<Vec3f> one = {s.worldPoints().front()};
  engine.insert(b, one, s.origin());
  EXPECT_FALSE(a.identical(b, &why));
  EXPECT_FALSE(why.empty());
}

TEST_F(SimMaps, BadPointsAreCountedAndDoNotChangeTheMap) {
  GridMap grid(0.3);
  update::UpdateEngine engine;
  const io::Scan s = sim.read(0);
  engine.insert(grid, s.worldPoints(), s.origin());
  const std::size_t known = grid.knownCells();
  GridMap before = GridMap(0.3);
  engine.insert(before, s.worldPoints(), s.origin());

  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const std::vector<Vec3f> bad = {{nan, 0, 0}, {0, inf, 0}, {1e9f, 0, 0}};
  const auto st = engine.insert(grid, bad, s.origin());
  ASSERT_TRUE(st.has_value());
  EXPECT_EQ(st->rejected, 3u);
  EXPECT_EQ(grid.knownCells(), known);
  std::string why;
  EXPECT_TRUE(grid.identical(before, &why)) << why;
  // A bad origin rejects the whole scan.
  EXPECT_FALSE(engine.insert(grid, s.worldPoints(), Vec3f(nan, 0, 0)).has_value());
  EXPECT_FALSE(engine.insert(grid, s.worldPoints(), Vec3f(1e7f, 0, 0)).has_value());
  EXPECT_TRUE(grid.identical(before, &why)) << why;
  // An empty scan changes nothing.
  EXPECT_TRUE(engine.insert(grid, {}, s.origin()).has_value());
  EXPECT_TRUE(grid.identical(before, &why)) << why;
}

TEST_F(SimMaps, OctreeSavesAsOctomapFiles) {
  OctreeMap octree(0.3);
  update::UpdateEngine engine;
  for (std::size_t i = 0; i < 3; ++i) {
    const io::Scan s = sim.read(i);
    engine.insert(octree, s.worldPoints(), s.origin());
  }
  EXPECT_EQ(octree.tree().size(), octree.tree().calcNumNodes()) << "node counter out of step with the tree";
  const auto dir = std::filesystem::temp_directory_path();
  const std::string ot = (dir / "densemap_test_map.ot").string(),
                    bt = (dir / "densemap_test_map.bt").string();
  const std::size_t nodes = octree.tree().size();
  ASSERT_TRUE(octree.tree().write(ot));
  // OctoMap's non-const writeBinary() turns the tree into max-likelihood in place; saving must not.
  ASSERT_TRUE(octree.tree().writeBinaryConst(bt));
  EXPECT_EQ(octree.tree().size(), nodes);
  std::unique_ptr<octomap::AbstractOcTree> read(octomap::AbstractOcTree::read(ot));
  ASSERT_NE(read, nullptr);
  auto* full = dynamic_cast<octomap::OcTree*>(read.get());
  ASSERT_NE(full, nullptr);
  std::string why;
  EXPECT_TRUE(identicalTrees(octree.tree(), *full, &why)) << why;
  octomap::OcTree binary(0.1);
  ASSERT_TRUE(binary.readBinary(bt));
  EXPECT_DOUBLE_EQ(binary.getResolution(), 0.3);
  EXPECT_GT(binary.getNumLeafNodes(), 0u);
  std::filesystem::remove(ot);
  std::filesystem::remove(bt);
}

}  // namespace
}  // namespace densemap::map
