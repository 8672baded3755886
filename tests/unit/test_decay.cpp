// Decay (decay.h): cells no scan observes again relax toward unknown; observed ones do not.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include <Eigen/Core>

#include "densemap/io/moving_box_room.h"
#include "densemap/map/grid_map.h"
#include "densemap/map/map_factory.h"
#include "densemap/update/update_engine.h"
#include "test_simulator.h"

namespace densemap {
namespace {

using geometry::Vec3f;
using map::GridMap;

using Box = io::MovingBoxRoom::Box;

/// A static sensor in a closed room; the box moves at scan 20 to a place that hides its old one.
class RoomWithABox : public ::testing::Test {
 protected:
  static constexpr double kScanPeriod = 0.1;  // 10 Hz
  static constexpr int kMoveAt = 20;

  /// Cells occupied in `m` whose centres lie inside `b` (grown by a little, for cells on its faces).
  static std::vector<geometry::VoxelKey> occupiedIn(const GridMap& m, const Box& b) {
    std::vector<geometry::VoxelKey> keys;
    m.forEachCell([&](const geometry::VoxelKey& k, float v) {
      const Eigen::Vector3d c = m.converter().toCoord(k).cast<double>();
      const bool inside = (c.array() > b.lo.array() - 0.05).all() && (c.array() < b.hi.array() + 0.05).all();
      if (inside && v > m.logOddsParams().occupied) keys.push_back(k);
    });
    return keys;
  }
  static bool occupied(const GridMap& m, const geometry::VoxelKey& k) {
    const auto v = m.logOdds(k);
    return v && *v > m.logOddsParams().occupied;
  }

  /// The wall cells every scan after the move hits (cells in the box's new shadow are not among them).
  static std::vector<geometry::VoxelKey> wallsStillSeen(const GridMap& m, const io::MovingBoxRoom& room) {
    std::vector<geometry::VoxelKey> keys;
    for (const Vec3f& p : room.read(room.size() - 1).worldPoints()) {
      geometry::VoxelKey k;
      if ((std::abs(p.x()) > 9.9f || std::abs(p.y()) > 9.9f) && m.converter().toKey(p, k)) keys.push_back(k);
    }
    return keys;
  }

  /// Scans at 10 Hz, `after` of them after the move; the cells occupied in the old place just before it.
  static std::vector<geometry::VoxelKey> run(GridMap& m, int after) {
    io::MovingBoxRoom room({kMoveAt + after, kMoveAt});
    update::UpdateEngine engine;
    std::vector<geometry::VoxelKey> old_cells;
    const auto noop = [](const std::function<void()>& commit) { commit(); };
    for (std::size_t i = 0; i < room.size(); ++i) {
      m.advanceTime(static_cast<double>(i) * kScanPeriod, noop);
      const io::Scan s = room.read(i);
      EXPECT_TRUE(engine.insert(m, s.worldPoints(), s.origin()));
      if (static_cast<int>(i) == kMoveAt - 1) old_cells = occupiedIn(m, room.oldPlace());
    }
    return old_cells;
  }
};

TEST_F(RoomWithABox, WithoutDecayAMovedBoxStaysInItsOldPlace) {
  GridMap m(0.2);
  const auto old_cells = run(m, 100);  // 10 s after the move
  ASSERT_GT(old_cells.size(), 20u);
  for (const auto& k : old_cells)
    EXPECT_TRUE(occupied(m, k)) << "no ray reaches the old place, nothing clears it";
}

TEST_F(RoomWithABox, DecayClearsTheOldPlaceWithinTheConfiguredTimeWhileWallsStay) {
  constexpr double kDecayS = 4.0, kStepS = 0.5;
  GridMap m(0.2);
  m.setDecay({kDecayS, kStepS});
  // Half the decay time after the move: the old place has faded but is still believed occupied somewhere.
  auto old_cells = run(m, static_cast<int>(kDecayS / 2 / kScanPeriod));
  ASSERT_GT(old_cells.size(), 20u);
  std::size_t still = 0;
  for (const auto& k : old_cells) still += occupied(m, k) ? 1 : 0;
  EXPECT_GT(still, 0u) << "decay is gradual: half-way, cells at the upper clamp are still occupied";

  GridMap m2(0.2);
  m2.setDecay({kDecayS, kStepS});
  // The configured time plus one step (decay comes in whole steps) after the move.
  const int after = static_cast<int>((kDecayS + kStepS) / kScanPeriod) + 1;
  old_cells = run(m2, after);
  const io::MovingBoxRoom room({kMoveAt + after, kMoveAt});
  const auto walls = wallsStillSeen(m2, room);
  ASSERT_GT(walls.size(), 1000u);
  for (const auto& k : old_cells) {
    EXPECT_FALSE(m2.logOdds(k).has_value()) << "the old place is unknown again";
  }
  std::size_t walls_kept = 0;
  for (const auto& k : walls) walls_kept += occupied(m2, k) ? 1 : 0;
  EXPECT_EQ(walls_kept, walls.size()) << "walls seen every scan stay occupied";
  EXPECT_GT(occupiedIn(m2, room.newPlace()).size(), 20u) << "the box's new place is occupied";
}

TEST(Decay, EveryMethodGivesTheSameMapWithDecayOn) {
  // Decay steps run between scans, so each scan's culling region is built on one consistent map.
  io::LidarSimulator sim(test::smallSimulator(12, 32, 512, 0.4));
  std::vector<std::unique_ptr<GridMap>> maps;
  const auto noop = [](const std::function<void()>& commit) { commit(); };
  for (auto method : update::kAllMethods) {
    auto m = std::make_unique<GridMap>(0.2);
    m->setDecay({2.0, 0.2});
    update::UpdateOptions o;
    o.method = method;
    update::UpdateEngine engine(o);
    for (std::size_t i = 0; i < sim.size(); ++i) {
      m->advanceTime(static_cast<double>(i) * 0.25, noop);
      const io::Scan s = sim.read(i);
      ASSERT_TRUE(engine.insert(*m, s.worldPoints(), s.origin()));
    }
    maps.push_back(std::move(m));
  }
  for (std::size_t i = 1; i < maps.size(); ++i) {
    std::string why;
    EXPECT_TRUE(maps[0]->identical(*maps[i], &why))
        << update::toString(update::kAllMethods[i]) << ": " << why;
  }
  // And decay changed the map: without it the same scans give another.
  GridMap plain(0.2);
  update::UpdateEngine engine;
  for (std::size_t i = 0; i < sim.size(); ++i) {
    const io::Scan s = sim.read(i);
    ASSERT_TRUE(engine.insert(plain, s.worldPoints(), s.origin()));
  }
  EXPECT_FALSE(plain.identical(*maps[0]));
}

TEST(Decay, ACellRelaxesLinearlyAndBlocksWithNothingKnownLeaveMemory) {
  GridMap m(0.2);
  m.setDecay({10.0, 1.0});
  const auto noop = [](const std::function<void()>& commit) { commit(); };
  m.advanceTime(100.0, noop);  // starts the clock
  geometry::VoxelKey k;
  ASSERT_TRUE(m.converter().toKey(Vec3f(1.0f, 2.0f, 3.0f), k));
  const float top = m.logOddsParams().max;
  m.setLogOdds(k, top);
  EXPECT_FALSE(m.advanceTime(100.5, noop)) << "less than a step: nothing happens";
  EXPECT_EQ(*m.logOdds(k), top);
  EXPECT_TRUE(m.advanceTime(102.0, noop));
  EXPECT_NEAR(*m.logOdds(k), top * 0.8f, 1e-5f) << "2 of 10 s: a fifth of the way to unknown";
  EXPECT_FALSE(m.advanceTime(50.0, noop)) << "time never runs backwards";
  EXPECT_EQ(m.blockCount(), 1u);
  m.advanceTime(110.5, noop);
  EXPECT_FALSE(m.logOdds(k).has_value());
  EXPECT_EQ(m.blockCount(), 0u) << "a block with nothing known is freed";
  EXPECT_DOUBLE_EQ(m.mapTime(), 110.5);
}

TEST(Decay, OnlyTheGridDecaysAndBadSettingsAreRefused) {
  map::MapOptions o;
  o.backend = "octree";
  o.decay.seconds_to_unknown = 5.0;
  EXPECT_THROW(map::makeMap(o), std::invalid_argument);
  o.backend = "grid";
  EXPECT_NO_THROW(map::makeMap(o));
  o.decay.step_s = 0.0;
  EXPECT_THROW(map::makeMap(o), std::invalid_argument);
  o.decay.step_s = 1.0;
  o.decay.seconds_to_unknown = std::nan("");
  EXPECT_THROW(map::makeMap(o), std::invalid_argument);
}

TEST(Decay, OffByDefaultTheMapIgnoresTime) {
  io::LidarSimulator sim(test::smallSimulator(4));
  GridMap a(0.2), b(0.2);
  update::UpdateEngine ea, eb;
  const auto noop = [](const std::function<void()>& commit) { commit(); };
  for (std::size_t i = 0; i < sim.size(); ++i) {
    const io::Scan s = sim.read(i);
    EXPECT_FALSE(b.advanceTime(static_cast<double>(i) * 100.0, noop));
    ASSERT_TRUE(ea.insert(a, s.worldPoints(), s.origin()));
    ASSERT_TRUE(eb.insert(b, s.worldPoints(), s.origin()));
  }
  std::string why;
  EXPECT_TRUE(a.identical(b, &why)) << why;
}

}  // namespace
}  // namespace densemap
