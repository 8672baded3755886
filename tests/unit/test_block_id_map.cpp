// The compact index of blocks (block_id_map.h): the same answers as a hash map of every block, in a
// fraction of its memory for blocks stored along a trajectory (the window's index must not grow
// the server's memory by a hash node per stored block).
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <unordered_map>
#include <vector>

#include "densemap/map/block_id_map.h"
#include "densemap/map/grid_map.h"

namespace densemap {
namespace {

using geometry::KeyCoord;
using geometry::VoxelKey;

std::uint64_t blockAt(int x, int y, int z) {
  return VoxelKey{{static_cast<KeyCoord>(x), static_cast<KeyCoord>(y), static_cast<KeyCoord>(z)}}.packed();
}

std::vector<std::pair<std::uint64_t, std::uint64_t>> sorted(const map::BlockIdMap<std::uint64_t>& m) {
  std::vector<std::pair<std::uint64_t, std::uint64_t>> out;
  m.forEach([&](std::uint64_t id, std::uint64_t v) { out.emplace_back(id, v); });
  std::sort(out.begin(), out.end());
  return out;
}

TEST(BlockIdMap, AnswersAsAHashMapOfEveryBlockUnderRandomInsertsAndErases) {
  std::mt19937 rng(22);
  // Blocks near each other (many per region) and far apart (one per region), at the key range's edges too.
  std::uniform_int_distribution<int> near(2040, 2060), any(0, 4095);
  map::BlockIdMap<std::uint64_t> m;
  std::unordered_map<std::uint64_t, std::uint64_t> reference;
  for (int step = 0; step < 20000; ++step) {
    const bool far = step % 5 == 0;
    const std::uint64_t id =
        far ? blockAt(any(rng), any(rng), any(rng)) : blockAt(near(rng), near(rng), near(rng) % 8 + 2040);
    if (rng() % 3 == 0) {
      ASSERT_EQ(m.erase(id), reference.erase(id) == 1) << step;
    } else {
      const std::uint64_t v = rng();
      ASSERT_EQ(m.insert(id, v), !reference.contains(id)) << step;
      reference[id] = v;
    }
    ASSERT_EQ(m.size(), reference.size());
    const std::uint64_t probe = blockAt(near(rng), near(rng), near(rng) % 8 + 2040);
    ASSERT_EQ(m.contains(probe), reference.contains(probe));
    const std::uint64_t* found = m.find(probe);
    ASSERT_EQ(found != nullptr, reference.contains(probe));
    if (found != nullptr) {
      ASSERT_EQ(*found, reference.at(probe));
    }
  }
  std::vector<std::pair<std::uint64_t, std::uint64_t>> expected(reference.begin(), reference.end());
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(sorted(m), expected);
  EXPECT_GT(m.size(), 1000u);
}

TEST(BlockIdMap, ABoxFindsExactlyTheBlocksInsideItWhetherSmallOrLarge) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> c(1000, 1100);
  map::BlockIdSet set;
  std::vector<std::uint64_t> all;
  for (int i = 0; i < 5000; ++i) {
    const std::uint64_t id = blockAt(c(rng), c(rng), c(rng) % 10 + 1000);
    if (set.insert(id)) all.push_back(id);
  }
  // Small boxes look regions up; a box larger than the set visits every region: both must agree with a scan.
  for (int span : {0, 1, 3, 7, 30, 200, 4000}) {
    for (int trial = 0; trial < 20; ++trial) {
      const int x = c(rng) - span / 2, y = c(rng) - span / 2,
                z = 1000 + static_cast<int>(rng() % 10) - span / 2;
      auto clamp = [](int v) { return static_cast<KeyCoord>(std::clamp(v, 0, 4095)); };
      const VoxelKey lo{{clamp(x), clamp(y), clamp(z)}},
          hi{{clamp(x + span), clamp(y + span), clamp(z + span)}};
      std::vector<std::uint64_t> got, expected;
      set.forEachInBox(lo, hi, [&](std::uint64_t id) { got.push_back(id); });
      for (std::uint64_t id : all) {
        const VoxelKey b = VoxelKey::fromPacked(id);
        if (b[0] >= lo[0] && b[0] <= hi[0] && b[1] >= lo[1] && b[1] <= hi[1] && b[2] >= lo[2] &&
            b[2] <= hi[2])
          expected.push_back(id);
      }
      std::sort(got.begin(), got.end());
      std::sort(expected.begin(), expected.end());
      ASSERT_EQ(got, expected) << "span " << span;
    }
  }
}

TEST(BlockIdMap, BlocksAlongATrajectoryCostAFewBytesEach) {
  // What the window stores behind a robot on a street: a band 60 blocks wide and 4 high, 2,000 blocks long.
  map::BlockIdMap<std::uint64_t> index;
  map::BlockIdSet out_of_memory;
  std::unordered_map<std::uint64_t, std::uint64_t> hashed;
  std::uint64_t version = 0;
  for (int x = 1000; x < 3000; ++x)
    for (int y = 2018; y < 2078; ++y)
      for (int z = 2046; z < 2050; ++z) {
        index.insert(blockAt(x, y, z), ++version);
        out_of_memory.insert(blockAt(x, y, z));
        hashed[blockAt(x, y, z)] = version;
      }
  const double per_block = static_cast<double>(index.memoryBytes() + out_of_memory.memoryBytes()) /
                           static_cast<double>(index.size());
  // A hash node per block costs 8 (bucket) + 32 (node) + 16 (allocator) bytes in each of the two.
  const double hashed_per_block =
      2.0 * (56.0 + static_cast<double>(hashed.bucket_count() * 8) / static_cast<double>(hashed.size()));
  RecordProperty("bytes_per_stored_block", std::to_string(per_block));
  EXPECT_LT(per_block, 14.0) << "8 bytes of version plus the regions' share";
  EXPECT_LT(per_block * 5.0, hashed_per_block);
}

TEST(BlockIdMap, OnlyIdsAGridCanMakeAreBlockIds) {
  EXPECT_TRUE(map::GridMap::isBlockId(blockAt(0, 0, 0)));
  EXPECT_TRUE(map::GridMap::isBlockId(blockAt(4095, 4095, 4095)));
  EXPECT_TRUE(map::GridMap::isBlockId(map::GridMap::blockIdOf(VoxelKey{{65535, 65535, 65535}})));
  EXPECT_FALSE(map::GridMap::isBlockId(blockAt(4096, 0, 0)));
  EXPECT_FALSE(map::GridMap::isBlockId(blockAt(0, 0, 4096)));
  EXPECT_FALSE(map::GridMap::isBlockId(std::uint64_t{1} << 48));
}

}  // namespace
}  // namespace densemap
