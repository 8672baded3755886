// The culling region (Sec. 2.3.5, Alg. 3): only fully free cells, closed toward the sensor (every test cell
// of a member is a member), limited to the scan's box; and rays walked into it may stop.
#include <vector>

#include <gtest/gtest.h>

#include "densemap/geometry/ray_traversal.h"
#include "densemap/io/lidar_simulator.h"
#include "densemap/map/grid_map.h"
#include "densemap/update/culling_region.h"
#include "densemap/update/update_engine.h"
#include "test_simulator.h"

namespace densemap::update {
namespace {

using geometry::VoxelKey;

struct CullingFixture : ::testing::Test {
  io::LidarSimulator sim{test::smallSimulator(12, 32, 720, 0.3)};
  map::GridMap grid{0.4};

  void mapScans(std::size_t n) {
    UpdateEngine engine(UpdateOptions{.method = UpdateMethod::kBaseline});
    for (std::size_t i = 0; i < n; ++i) {
      const io::Scan s = sim.read(i);
      ASSERT_TRUE(engine.insert(grid, s.worldPoints(), s.origin()).has_value());
    }
  }
};

TEST_F(CullingFixture, RegionIsFullyFreeAndClosedTowardTheSensor) {
  mapScans(8);  // batch semantics needs 5 scans before a cell clamps at the free bound
  const io::Scan next = sim.read(8);
  VoxelKey o;
  ASSERT_TRUE(grid.converter().toKey(next.origin(), o));
  map::ScanEvidence ev;
  VoxelKey lo = o, hi = o;
  for (int a = 0; a < 3; ++a) {
    lo[a] = static_cast<geometry::KeyCoord>(o[a] - 60);
    hi[a] = static_cast<geometry::KeyCoord>(o[a] + 60);
  }
  ev.reset(lo, hi, false);
  const auto st = CullingRegion::build(grid, o, ev);
  ASSERT_GT(st.cells, 100u) << "after 8 scans the space around the sensor is fully free";
  std::size_t members = 0;
  ev.forEachBlock([&](const map::EvidenceBlock& b) {
    for (int i = 0; i < map::kBlockVoxels; ++i) {
      if (!b.region.test(i)) continue;
      ++members;
      const VoxelKey c = b.voxelKey(i);
      EXPECT_TRUE(grid.isFullyFree(c));
      EXPECT_TRUE(ev.insideBox(c));
      for (int a = 0; a < 3; ++a) {
        const int d = int(c[a]) - int(o[a]);
        if (d == 0) continue;
        VoxelKey t = c;
        t[a] = static_cast<geometry::KeyCoord>(int(c[a]) - (d > 0 ? 1 : -1));
        EXPECT_TRUE(ev.inRegion(t)) << "test cell of a member must be a member";
      }
    }
  });
  EXPECT_EQ(members, st.cells);
  // Property: any ray from a member cell's centre back to the sensor stays inside the region.
  ev.forEachBlock([&](const map::EvidenceBlock& b) {
    for (int i = 0; i < map::kBlockVoxels; i += 7) {
      if (!b.region.test(i)) continue;
      geometry::RaySetup r;
      ASSERT_TRUE(
          geometry::setupRay(grid.converter(), next.origin(), grid.converter().toCoord(b.voxelKey(i)), r));
      geometry::walkForward(r, [&](const VoxelKey& k) { EXPECT_TRUE(ev.inRegion(k)); });
    }
  });
}

TEST_F(CullingFixture, EmptyMapGivesEmptyRegion) {
  map::ScanEvidence ev;
  VoxelKey o;
  ASSERT_TRUE(grid.converter().toKey(sim.read(0).origin(), o));
  ev.reset(o, o, false);
  EXPECT_EQ(CullingRegion::build(grid, o, ev).cells, 0u);
}

TEST_F(CullingFixture, CullingSkipsTraversalsAndKeepsTheMap) {
  mapScans(8);
  map::GridMap copy_culled{0.4}, copy_base{0.4};
  // Replay the same 9 scans into two fresh maps, with and without culling, counting traversals.
  UpdateEngine base(UpdateOptions{.method = UpdateMethod::kBaseline});
  UpdateEngine cull(UpdateOptions{.method = UpdateMethod::kCullingRegion, .in_scan_closure = false});
  std::uint64_t tb = 0, tc = 0, region = 0;
  for (std::size_t i = 0; i < 10; ++i) {
    const io::Scan s = sim.read(i);
    tb += base.insert(copy_base, s.worldPoints(), s.origin())->traversed;
    const auto st = cull.insert(copy_culled, s.worldPoints(), s.origin());
    tc += st->traversed;
    region += st->region_cells;
  }
  EXPECT_GT(region, 0u);
  EXPECT_LT(tc, tb) << "the region must stop rays early";
  std::string why;
  EXPECT_TRUE(copy_base.identical(copy_culled, &why)) << why;
}

}  // namespace
}  // namespace densemap::update
