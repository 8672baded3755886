// Compact cells (palette_block.h): a byte per voxel into the block's distinct values, bit for bit.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include "densemap/io/scan_source.h"
#include "densemap/map/grid_map.h"
#include "densemap/map/octree_map.h"
#include "densemap/sources/open_source.h"
#include "densemap/update/update_engine.h"
#include "test_data.h"
#include "test_simulator.h"

namespace densemap {
namespace {

using map::GridMap;
using map::PaletteBlock;

std::uint32_t bits(float v) { return std::bit_cast<std::uint32_t>(v); }

TEST(PaletteBlock, StartsUnknownAndKeepsValuesBitForBit) {
  PaletteBlock b;
  EXPECT_EQ(b.knownCount(), 0u);
  EXPECT_FALSE(b.anyKnown());
  EXPECT_TRUE(std::isnan(b.get(17)));
  const float tiny = std::nextafter(0.4f, 1.0f);
  b.set(3, 0.4f);
  b.set(4, tiny);
  b.set(5, -0.0f);
  b.set(6, 0.0f);
  EXPECT_EQ(bits(b.get(3)), bits(0.4f));
  EXPECT_EQ(bits(b.get(4)), bits(tiny)) << "values one ulp apart stay apart";
  EXPECT_EQ(bits(b.get(5)), bits(-0.0f)) << "-0 and +0 are different bits";
  EXPECT_EQ(bits(b.get(6)), bits(0.0f));
  EXPECT_EQ(b.knownCount(), 4u);
  EXPECT_FALSE(b.dense());
  EXPECT_EQ(b.paletteSize(), 5u);
}

TEST(PaletteBlock, StaleEntriesAreDroppedWhenThePaletteFills) {
  PaletteBlock b;
  // One voxel takes 1,000 values in turn: the palette fills with values nobody uses any more, is compacted,
  // and the block never needs a float per voxel.
  for (int k = 0; k < 1000; ++k) {
    b.set(0, static_cast<float>(k) * 0.01f);
    b.set(1, 7.0f);
    ASSERT_EQ(bits(b.get(0)), bits(static_cast<float>(k) * 0.01f)) << k;
  }
  EXPECT_FALSE(b.dense());
  EXPECT_LE(b.paletteSize(), PaletteBlock::kMaxPalette);
  EXPECT_EQ(b.get(1), 7.0f);
  EXPECT_EQ(b.knownCount(), 2u);
}

TEST(PaletteBlock, MoreThan256DistinctValuesFallBackToFloats) {
  PaletteBlock b;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f);
  std::vector<float> want(map::kBlockVoxels);
  for (int i = 0; i < map::kBlockVoxels; ++i) {
    want[static_cast<std::size_t>(i)] = u(rng);
    b.set(i, want[static_cast<std::size_t>(i)]);
  }
  EXPECT_TRUE(b.dense());
  for (int i = 0; i < map::kBlockVoxels; ++i)
    ASSERT_EQ(bits(b.get(i)), bits(want[static_cast<std::size_t>(i)]));
  EXPECT_EQ(b.knownCount(), static_cast<std::size_t>(map::kBlockVoxels));
  // A copy is a deep copy.
  PaletteBlock c = b;
  c.set(0, 1.0f);
  EXPECT_EQ(bits(b.get(0)), bits(want[0]));
  EXPECT_GT(b.memoryBytes(), sizeof(float) * map::kBlockVoxels);
}

TEST(PaletteBlock, TransformValuesChangesEveryVoxelOfAValue) {
  PaletteBlock b;
  for (int i = 0; i < 100; ++i) b.set(i, i % 2 ? 1.0f : -1.0f);
  b.transformValues([](float v) { return std::isnan(v) ? v : v * 2.0f; });
  for (int i = 0; i < 100; ++i) ASSERT_EQ(b.get(i), i % 2 ? 2.0f : -2.0f);
  EXPECT_TRUE(std::isnan(b.get(100)));
}

/// Both semantics: the palette grid holds exactly OctoMap's cells (the counting semantics' values are many
/// and varied, so blocks compact or go dense there).
class CompactGridVsOctree : public ::testing::TestWithParam<map::UpdateSemantics> {};

TEST_P(CompactGridVsOctree, SameCellsBitForBit) {
  io::LidarSimulator sim(test::smallSimulator(20, 64, 1024, 0.3, 0.05));
  GridMap grid(0.4);
  map::OctreeMap octree(0.4);
  update::UpdateOptions o;
  o.semantics = GetParam();
  update::UpdateEngine a(o), b(o);
  for (std::size_t i = 0; i < sim.size(); ++i) {
    const io::Scan s = sim.read(i);
    ASSERT_TRUE(a.insert(grid, s.worldPoints(), s.origin()));
    ASSERT_TRUE(b.insert(octree, s.worldPoints(), s.origin()));
  }
  ASSERT_EQ(grid.knownCells(), octree.knownCells());
  std::size_t compared = 0;
  grid.forEachCell([&](const geometry::VoxelKey& k, float v) {
    const auto w = octree.logOdds(k);
    ASSERT_TRUE(w.has_value());
    ASSERT_EQ(bits(v), bits(*w));
    ++compared;
  });
  EXPECT_GT(compared, 50000u);
}

/// Evidence made up cell by cell, so palettes fill, are compacted in the middle of a block's update and
/// go dense: every value still equals OctoMap's update rule applied to a float per cell, under in-place
/// and published applies. Seeded random scenarios; `weighted_percent` sets how many cells per scan get a
/// weighted update (a new value) against single updates (transitions the block update remembers).
/// Returns the number of blocks that went dense.
std::size_t expectPaletteUpdatesExact(std::uint32_t seed, int weighted_percent, int scans) {
  GridMap in_place(0.2), published(0.2);
  constexpr int kCells = 2 * map::kBlockVoxels;
  std::vector<float> want(kCells, std::numeric_limits<float>::quiet_NaN());
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, 999), weight(2, 60);
  map::ScanEvidence ev;
  auto keyOf = [](int i) {
    return geometry::VoxelKey{{static_cast<geometry::KeyCoord>(32768 + i % 32),
                               static_cast<geometry::KeyCoord>(32768 + (i / 32) % 16),
                               static_cast<geometry::KeyCoord>(32768 + i / 512)}};
  };
  for (int scan = 0; scan < scans; ++scan) {
    ev.reset(keyOf(0), keyOf(kCells - 1), /*counting=*/true);
    for (int i = 0; i < kCells; ++i) {
      const int r = pick(rng);
      std::uint32_t nf = 0, nh = 0;
      if (r < weighted_percent * 10) {
        (r % 2 ? nf : nh) = static_cast<std::uint32_t>(weight(rng));
      } else if (r < 600) {
        nf = 1;
      } else if (r < 900) {
        nh = 1;
      } else {
        continue;
      }
      if (nf) ev.addFree(keyOf(i), nf);
      if (nh) ev.addHit(keyOf(i), nh);
      float& w = want[static_cast<std::size_t>(i)];
      w = map::applyCellUpdate(std::isnan(w) ? 0.0f : w, nf, nh, in_place.logOddsParams());
    }
    in_place.apply(ev);
    published.applyPublished(ev, [](const std::function<void()>& commit) { commit(); });
    for (int i = 0; i < kCells; ++i) {
      const float w = want[static_cast<std::size_t>(i)];
      for (const GridMap* m : {&in_place, &published}) {
        const auto v = m->logOdds(keyOf(i));
        EXPECT_EQ(v.has_value(), !std::isnan(w)) << i;
        if (bits(v.value_or(w)) != bits(w)) {
          ADD_FAILURE() << "seed " << seed << " scan " << scan << " cell " << i;
          return 0;
        }
      }
    }
  }
  return in_place.denseBlockCount();
}

TEST(CompactCells, PalettesThatFillCompactOrGoDenseInTheMiddleOfAnUpdateKeepEveryValue) {
  std::size_t dense = 0;
  for (std::uint32_t seed = 1; seed <= 4; ++seed) dense += expectPaletteUpdatesExact(seed, 1, 200);
  EXPECT_GT(dense, 0u) << "some block should have needed more than 256 values at once";
}

INSTANTIATE_TEST_SUITE_P(Semantics, CompactGridVsOctree,
                         ::testing::Values(map::UpdateSemantics::kBatch, map::UpdateSemantics::kCounting),
                         [](const auto& info) { return std::string(map::toString(info.param)); });

/// The grid's bytes per known cell: a quarter of a float per voxel slot, plus the blocks' palettes.
TEST(CompactCells, TheGridTakesFewBytesPerKnownCellOnTheSimulator) {
  io::LidarSimulator sim(test::smallSimulator(10));
  GridMap grid(0.2);
  update::UpdateEngine engine;
  for (std::size_t i = 0; i < sim.size(); ++i) {
    const io::Scan s = sim.read(i);
    ASSERT_TRUE(engine.insert(grid, s.worldPoints(), s.origin()));
  }
  const double per_cell = static_cast<double>(grid.memoryBytes()) / static_cast<double>(grid.knownCells());
  std::printf(
      "simulator, 10 scans at 0.2 m: %zu known cells in %zu blocks, %.0f bytes, %.2f bytes per cell\n",
      grid.knownCells(), grid.blockCount(), static_cast<double>(grid.memoryBytes()), per_cell);
  // A float per voxel slot in the same blocks would be 4 bytes per slot: the byte index is a quarter.
  const double float_grid = static_cast<double>(grid.blockCount()) * map::kBlockVoxels * sizeof(float);
  EXPECT_LT(static_cast<double>(grid.memoryBytes()), 0.4 * float_grid);
}

TEST(CompactCells, Kitti00FirstTenScansAtTwentyCentimetresFitInTenMegabytes) {
  DENSEMAP_REQUIRE_DATA("kitti00");
  auto src = sources::openSource(test::dataDir() + "/kitti00");
  GridMap grid(0.2);
  update::UpdateEngine engine;
  for (std::size_t i = 0; i < 10; ++i) {
    const io::Scan s = src->read(i);
    ASSERT_TRUE(engine.insert(grid, s.worldPoints(), s.origin()));
  }
  std::printf("kitti00 0-9 at 0.2 m: %zu known cells, %.2f MB, %.2f bytes per known cell\n",
              grid.knownCells(), static_cast<double>(grid.memoryBytes()) / 1e6,
              static_cast<double>(grid.memoryBytes()) / static_cast<double>(grid.knownCells()));
  EXPECT_EQ(grid.knownCells(), 1341992u) << "the same cells as OctoMap (the count)";
  EXPECT_LT(grid.memoryBytes(), 10'000'000u);
}

}  // namespace
}  // namespace densemap
