// Blocks out of memory (the rolling window, first part): a block leaves memory as bytes and comes
// back bit for bit; a map whose far blocks left and came back before the scans reached them is the map
// that kept them; a scan never overwrites a block that is out of memory.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>
#include <unordered_map>

#include "densemap/map/grid_map.h"
#include "densemap/update/update_engine.h"
#include "densemap/util/byte_codec.h"
#include "test_simulator.h"

namespace densemap {
namespace {

using map::GridMap;
using map::PaletteBlock;

std::uint32_t bits(float v) { return std::bit_cast<std::uint32_t>(v); }

void expectSameBlock(const PaletteBlock& a, const PaletteBlock& b) {
  EXPECT_EQ(a.dense(), b.dense());
  EXPECT_EQ(a.time_s, b.time_s);
  EXPECT_EQ(a.last_scan, b.last_scan);
  for (int i = 0; i < map::kBlockVoxels; ++i) ASSERT_EQ(bits(a.get(i)), bits(b.get(i))) << i;
}

TEST(MapBlockBytes, PaletteAndDenseBlocksRoundTripBitForBit) {
  PaletteBlock p;
  p.time_s = 12.5;
  p.last_scan = 7;
  for (int i = 0; i < 300; ++i) p.set(i * 13 % map::kBlockVoxels, static_cast<float>(i % 40) * 0.1f - 2.0f);
  expectSameBlock(p, PaletteBlock::decode(p.encode()));
  EXPECT_LT(p.encode().size(), 4400u) << "a byte per voxel plus the palette";

  PaletteBlock d;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f);
  for (int i = 0; i < map::kBlockVoxels; ++i) d.set(i, u(rng));
  ASSERT_TRUE(d.dense());
  expectSameBlock(d, PaletteBlock::decode(d.encode()));
}

TEST(MapBlockBytes, DamagedBytesAreRefusedWithWhatIsWrong) {
  PaletteBlock p;
  p.set(5, 1.0f);
  const std::string good = p.encode();
  auto refused = [](std::string bytes, const std::string& why) {
    try {
      PaletteBlock::decode(bytes);
      ADD_FAILURE() << "read: " << why;
    } catch (const util::FormatError& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  refused(good.substr(0, good.size() - 1), "indices");
  refused(good + "x", "bytes after the block");
  std::string magic = good;
  magic[0] ^= 1;
  refused(magic, "not a densemap map block");
  std::string time = good;
  const double inf = std::numeric_limits<double>::infinity();
  std::memcpy(time.data() + 4, &inf, 8);
  refused(time, "time is not finite");
  std::string mode = good;
  mode[20] = 9;
  refused(mode, "block mode 9");
  std::string size = good;
  const std::uint16_t big = 300;
  std::memcpy(size.data() + 21, &big, 2);
  refused(size, "palette size 300");
  std::string index = good;
  index[index.size() - 1] = 7;  // the palette has 2 entries
  refused(index, "index past the palette");
  std::string first = good;
  const float one = 1.0f;
  std::memcpy(first.data() + 23, &one, 4);
  refused(first, "first entry is not 'unknown'");
}

class WindowOnTheSimulator : public ::testing::Test {
 protected:
  io::LidarSimulator sim{test::smallSimulator(16, 32, 512, 2.0)};
  /// The key box of a scan's rays (its points and origin).
  static std::pair<geometry::VoxelKey, geometry::VoxelKey> keyBox(const GridMap& m, const io::Scan& s) {
    geometry::VoxelKey lo, hi;
    m.converter().toKey(s.origin(), lo);
    hi = lo;
    for (const auto& p : s.worldPoints()) {
      geometry::VoxelKey k;
      if (!m.converter().toKey(p, k)) continue;
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], k[a]);
        hi[a] = std::max(hi[a], k[a]);
      }
    }
    return {lo, hi};
  }
};

TEST_F(WindowOnTheSimulator, BlocksThatLeftAndCameBackBeforeTheScansReachedThemGiveTheSameMap) {
  GridMap kept(0.2), windowed(0.2);
  update::UpdateEngine a, b;
  std::unordered_map<std::uint64_t, std::string> stored;  // what a block store would hold
  std::size_t left = 0, came_back = 0;
  for (std::size_t i = 0; i < sim.size(); ++i) {
    const io::Scan s = sim.read(i);
    ASSERT_TRUE(a.insert(kept, s.worldPoints(), s.origin()));
    const auto [lo, hi] = keyBox(windowed, s);
    for (std::uint64_t id : windowed.outOfMemoryIn(lo, hi)) {
      windowed.putBlock(id, std::make_unique<PaletteBlock>(PaletteBlock::decode(stored.at(id))));
      stored.erase(id);
      ++came_back;
    }
    ASSERT_TRUE(b.insert(windowed, s.worldPoints(), s.origin()));
    // A 15 m window around the sensor (the simulator drives 2 m per scan along a street).
    const geometry::Vec3f here = s.origin();
    for (std::uint64_t id : windowed.blocksFartherThan({&here, 1}, 15.0)) {
      stored[id] = windowed.takeBlock(id)->encode();
      ++left;
    }
    EXPECT_LT(windowed.blockCount(), kept.blockCount());
  }
  EXPECT_GT(left, 100u);
  for (auto& [id, bytes] : stored)
    windowed.putBlock(id, std::make_unique<PaletteBlock>(PaletteBlock::decode(bytes)));
  EXPECT_EQ(windowed.outOfMemoryCount(), 0u);
  std::string why;
  EXPECT_TRUE(kept.identical(windowed, &why))
      << why << " (" << left << " left, " << came_back << " came back)";
}

TEST_F(WindowOnTheSimulator, AScanReachingABlockOutOfMemoryIsRefusedBeforeAnythingChanges) {
  GridMap m(0.2);
  update::UpdateEngine engine;
  const io::Scan s0 = sim.read(0);
  ASSERT_TRUE(engine.insert(m, s0.worldPoints(), s0.origin()));
  geometry::VoxelKey k;
  ASSERT_TRUE(m.converter().toKey(s0.origin(), k));
  const std::uint64_t id = GridMap::blockIdOf(k);
  ASSERT_TRUE(m.takeBlock(id));
  EXPECT_FALSE(m.inMemory(k));
  const std::unique_ptr<map::OccupancyMap> before = m.clone();
  for (bool published : {false, true}) {
    update::UpdateEngine e;
    EXPECT_THROW(published ? e.insert(m, s0.worldPoints(), s0.origin(),
                                      [](const std::function<void()>& commit) { commit(); })
                           : e.insert(m, s0.worldPoints(), s0.origin()),
                 std::logic_error);
  }
  std::string why;
  EXPECT_TRUE(static_cast<const GridMap&>(*before).identical(m, &why)) << why;
}

TEST_F(WindowOnTheSimulator, TheLeastRecentlyUpdatedLeaveFirstAndTheLastScansNever) {
  GridMap m(0.2);
  update::UpdateEngine engine;
  for (std::size_t i = 0; i < 6; ++i) {
    const io::Scan s = sim.read(i);
    ASSERT_TRUE(engine.insert(m, s.worldPoints(), s.origin()));
  }
  const auto ids = m.leastRecentlyUpdated(m.memoryBytes() / 2);
  ASSERT_FALSE(ids.empty());
  std::uint64_t previous = 0;
  for (std::uint64_t id : ids) {
    const geometry::VoxelKey bk = geometry::VoxelKey::fromPacked(id);  // the block's key: voxel key >> 4
    const PaletteBlock* b =
        m.findBlock(geometry::VoxelKey{{static_cast<geometry::KeyCoord>(bk[0] << map::kBlockShift),
                                        static_cast<geometry::KeyCoord>(bk[1] << map::kBlockShift),
                                        static_cast<geometry::KeyCoord>(bk[2] << map::kBlockShift)}});
    ASSERT_NE(b, nullptr);
    EXPECT_GE(b->last_scan, previous) << "oldest first";
    EXPECT_LT(b->last_scan, m.scansApplied()) << "never a block the last scan changed";
    previous = b->last_scan;
  }
}

TEST(MapWindow, ABlockComingBackTakesTheDecayItMissed) {
  GridMap m(0.2);
  m.setDecay({10.0, 1.0});
  const auto noop = [](const std::function<void()>& commit) { commit(); };
  m.advanceTime(0.0, noop);
  geometry::VoxelKey k;
  ASSERT_TRUE(m.converter().toKey(geometry::Vec3f(1.0f, 1.0f, 1.0f), k));
  m.setLogOdds(k, m.logOddsParams().max);
  auto away = m.takeBlock(GridMap::blockIdOf(k));
  m.advanceTime(5.0, noop);  // half the decay time while it was out
  m.putBlock(GridMap::blockIdOf(k), std::move(away));
  ASSERT_TRUE(m.logOdds(k).has_value());
  EXPECT_NEAR(*m.logOdds(k), m.logOddsParams().max * 0.5f, 1e-5f);
}

}  // namespace
}  // namespace densemap
