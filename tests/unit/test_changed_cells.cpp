// UpdateStats::changed_cells and updated_cells: the distinct cells whose value a scan changes
// (the floor of any exact method's work) and those it gives evidence. Checked against the map itself (on
// an empty map every updated cell becomes known) and across the four methods (the same cells change
// whichever walk found them).
#include <gtest/gtest.h>

#include "densemap/io/lidar_simulator.h"
#include "densemap/map/map_factory.h"
#include "densemap/update/update_engine.h"
#include "test_simulator.h"

namespace densemap::update {
namespace {

UpdateEngine countingEngine(UpdateMethod m) {
  UpdateOptions o;
  o.method = m;
  o.count_cells = true;
  return UpdateEngine(o);
}

TEST(ChangedCells, OnAnEmptyMapEveryUpdatedCellBecomesKnown) {
  io::LidarSimulator sim(test::smallSimulator(1));
  const io::Scan s = sim.read(0);
  for (const char* backend : {"grid", "octree"})
    for (UpdateMethod m : kAllMethods) {
      auto map = map::makeMap({backend, 0.2, {}});
      UpdateEngine engine = countingEngine(m);
      const auto st = engine.insert(*map, s.worldPoints(), s.origin());
      ASSERT_TRUE(st);
      EXPECT_GT(st->changed_cells, 1000u);
      EXPECT_EQ(st->updated_cells, map->knownCells()) << backend << " " << toString(m);
      EXPECT_EQ(st->changed_cells, map->knownCells()) << backend << " " << toString(m);
      // On an empty map there is no culling region yet, so every method walks each cell it changes.
      EXPECT_GE(st->traversed, st->changed_cells) << backend << " " << toString(m);
    }
}

TEST(ChangedCells, EveryMethodChangesTheSameCellsScanAfterScan) {
  io::LidarSimulator sim(test::smallSimulator(8));
  std::vector<std::vector<std::uint64_t>> changed, updated;
  for (UpdateMethod m : kAllMethods) {
    auto map = map::makeMap({"grid", 0.2, {}});
    UpdateEngine engine = countingEngine(m);
    auto& c = changed.emplace_back();
    auto& u = updated.emplace_back();
    for (std::size_t i = 0; i < 8; ++i) {
      const io::Scan s = sim.read(i);
      const auto st = engine.insert(*map, s.worldPoints(), s.origin());
      ASSERT_TRUE(st);
      c.push_back(st->changed_cells);
      u.push_back(st->updated_cells);
    }
  }
  for (std::size_t m = 1; m < changed.size(); ++m)
    EXPECT_EQ(changed[m], changed[0]) << toString(kAllMethods[m]);
  // Later scans cross cells that are already fully free: the baseline still updates them (no change),
  // the culling methods skip them. So updated >= changed, with equality somewhere only by chance.
  for (std::size_t m = 0; m < changed.size(); ++m)
    for (std::size_t i = 0; i < changed[m].size(); ++i) EXPECT_GE(updated[m][i], changed[m][i]);
  EXPECT_GT(updated[0].back(), changed[0].back()) << "the baseline re-updates fully free cells";
}

TEST(ChangedCells, NotCountedUnlessAsked) {
  io::LidarSimulator sim(test::smallSimulator(1));
  const io::Scan s = sim.read(0);
  auto map = map::makeMap({"grid", 0.2, {}});
  UpdateEngine engine;
  const auto st = engine.insert(*map, s.worldPoints(), s.origin());
  ASSERT_TRUE(st);
  EXPECT_EQ(st->changed_cells, 0u);
  EXPECT_EQ(st->updated_cells, 0u);
}

}  // namespace
}  // namespace densemap::update
