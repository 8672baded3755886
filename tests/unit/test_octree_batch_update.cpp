// The octree's batch update (OctreeMap::apply) against OctoMap's own updateNode, cell by cell, on trees that
// hold pruned leaves: above the depth where apply splits the tree into parallel subtrees (a 32^3 or 64^3
// cube of clamped cells), at that depth (16^3) and below it. OctoMap's early abort skips clamped cells; a
// pruned leaf is expanded only for the cells that change, and a leaf whose every cell changes alike stays
// one leaf. The trees must be equal node for node, whatever the thread count.
#include <algorithm>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <omp.h>

#include "densemap/map/octree_map.h"
#include "densemap/map/scan_evidence.h"

namespace densemap::map {
namespace {

using Key = std::array<unsigned, 3>;

VoxelKey voxelKey(const Key& k) {
  return VoxelKey{{static_cast<geometry::KeyCoord>(k[0]), static_cast<geometry::KeyCoord>(k[1]),
                   static_cast<geometry::KeyCoord>(k[2])}};
}
octomap::OcTreeKey octKey(const Key& k) {
  return octomap::OcTreeKey(static_cast<octomap::key_type>(k[0]), static_cast<octomap::key_type>(k[1]),
                            static_cast<octomap::key_type>(k[2]));
}

/// One scan's batch evidence: cells crossed and cells hit (a cell in both counts as hit).
struct Evidence {
  std::set<Key> free, hit;
};

/// A tree with a prefilled cube of `side` cells from `base`, every cell set to `value` (OctoMap prunes it
/// into one leaf when the cube is an aligned node).
void fillCube(octomap::OcTree& tree, const Key& base, unsigned side, float value) {
  for (unsigned x = 0; x < side; ++x)
    for (unsigned y = 0; y < side; ++y)
      for (unsigned z = 0; z < side; ++z)
        tree.setNodeValue(octKey({base[0] + x, base[1] + y, base[2] + z}), value, false);
}

class OctreeBatchUpdate : public ::testing::TestWithParam<int> {
 protected:
  void SetUp() override { omp_set_num_threads(GetParam()); }
  void TearDown() override { omp_set_num_threads(threads_before_); }

  /// Prefills both trees alike.
  template <class F>
  void prefill(F&& f) {
    f(map_.mutableTree());
    f(reference_);
  }

  /// Applies the evidence through OctreeMap::apply and, to the reference, through OctoMap's updateNode
  /// (misses first, then hits, as insertPointCloud does); the trees must then be identical.
  /// `box_margin` > 0 moves the evidence box's sides inwards by that many cells, so that the cells near the
  /// border are recorded as overflow cells (with a margin beyond the cells' extent, the box is empty).
  void applyAndCompare(const Evidence& ev, const std::string& what, unsigned box_margin = 0) {
    Key lo{~0u, ~0u, ~0u}, hi{0, 0, 0};
    for (const auto* cells : {&ev.free, &ev.hit})
      for (const Key& k : *cells)
        for (std::size_t a = 0; a < 3; ++a) {
          lo[a] = std::min(lo[a], k[a]);
          hi[a] = std::max(hi[a], k[a]);
        }
    for (std::size_t a = 0; a < 3; ++a) {
      lo[a] += box_margin;
      hi[a] -= box_margin;
    }
    evidence_.reset(voxelKey(lo), voxelKey(hi), false);
    for (const Key& k : ev.free) evidence_.markFree(voxelKey(k));
    for (const Key& k : ev.hit) evidence_.markHit(voxelKey(k));
    evidence_.resolveOccupiedWins();
    if (box_margin > 0) {
      ASSERT_GT(evidence_.overflowCount(), 0u) << what;
    }
    map_.apply(evidence_);
    for (const Key& k : ev.free)
      if (!ev.hit.contains(k)) reference_.updateNode(octKey(k), false, false);
    for (const Key& k : ev.hit) reference_.updateNode(octKey(k), true, false);
    std::string why;
    ASSERT_TRUE(identicalTrees(map_.tree(), reference_, &why)) << what << ": " << why;
    ASSERT_EQ(map_.tree().size(), reference_.size()) << what;
  }

  static constexpr unsigned kC = 32768;  // the key of the map's centre
  const int threads_before_ = omp_get_max_threads();
  OctreeMap map_{0.2};
  std::unique_ptr<octomap::OcTree> reference_owner_ = OctreeMap::makeTree(0.2, OccupancyParams{});
  octomap::OcTree& reference_ = *reference_owner_;
  ScanEvidence evidence_;
  std::mt19937 rng_{7};
};

TEST_P(OctreeBatchUpdate, PrunedLeavesAboveTheSplitDepthAreExpandedOnlyWhereCellsChange) {
  const float free_min = reference_.getClampingThresMinLog();
  const float occ_max = reference_.getClampingThresMaxLog();
  // A 64^3 cube of clamped free cells (one leaf at depth 10) and a 32^3 cube of clamped occupied cells
  // (depth 11) beside it, plus a few loose cells.
  prefill([&](octomap::OcTree& t) {
    fillCube(t, {kC, kC, kC}, 64, free_min);
    fillCube(t, {kC + 64, kC, kC}, 32, occ_max);
    t.updateNode(octKey({kC - 5, kC + 3, kC + 70}), true, false);
  });
  ASSERT_LT(map_.tree().size(), 40u) << "the cubes should be pruned into single leaves";
  std::uniform_int_distribution<unsigned> in64(0, 63), x_range(0, 127), yz_range(0, 79);

  // Misses in the free cube and hits in the occupied one: OctoMap's early abort leaves both leaves alone.
  Evidence noop;
  for (int i = 0; i < 500; ++i) noop.free.insert({kC + in64(rng_), kC + in64(rng_), kC + in64(rng_)});
  for (int i = 0; i < 200; ++i)
    noop.hit.insert({kC + 64 + in64(rng_) / 2, kC + in64(rng_) / 2, kC + in64(rng_) / 2});
  applyAndCompare(noop, "no-op evidence");
  ASSERT_LT(map_.tree().size(), 40u);

  // Random misses and hits across both cubes and around them: both leaves expand where cells change.
  for (int round = 0; round < 3; ++round) {
    Evidence mixed;
    for (int i = 0; i < 3000; ++i) {
      const Key k{kC - 16 + x_range(rng_), kC - 8 + yz_range(rng_), kC - 8 + yz_range(rng_)};
      ((rng_() % 4) == 0 ? mixed.hit : mixed.free).insert(k);
    }
    applyAndCompare(mixed, "mixed evidence, round " + std::to_string(round));
  }
}

TEST_P(OctreeBatchUpdate, ALeafWhoseEveryCellChangesAlikeStaysOneLeaf) {
  const float free_min = reference_.getClampingThresMinLog();
  // A 32^3 cube (depth 11, above the split depth) and a 16^3 cube (depth 12, at it) of clamped free cells.
  prefill([&](octomap::OcTree& t) {
    fillCube(t, {kC, kC, kC}, 32, free_min);
    fillCube(t, {kC + 32, kC, kC}, 16, free_min);
  });
  const std::size_t nodes = map_.tree().size();
  // Every cell of both cubes hit once: every cell gets the same value, so each cube stays one leaf.
  Evidence all_hit;
  for (unsigned x = 0; x < 48; ++x)
    for (unsigned y = 0; y < 32; ++y)
      for (unsigned z = 0; z < 32; ++z)
        if (x < 32 || (y < 16 && z < 16)) all_hit.hit.insert({kC + x, kC + y, kC + z});
  applyAndCompare(all_hit, "every cell hit");
  EXPECT_EQ(map_.tree().size(), nodes);
  // Every cell but one hit again: the leaves expand (the missing cell keeps its value).
  all_hit.hit.erase({kC + 31, kC + 31, kC + 31});
  all_hit.hit.erase({kC + 40, kC + 3, kC + 9});
  applyAndCompare(all_hit, "every cell but one hit");
  EXPECT_GT(map_.tree().size(), nodes);
}

TEST_P(OctreeBatchUpdate, AFreshTreeAndCellsOutsideTheEvidenceBoxMatchOctomap) {
  // No prefill: the first cell creates the root. Then cells far apart, so that most blocks have a single
  // cell and the upper levels are created along many paths. Round 2's evidence box leaves out a border of
  // them and round 3's is empty (every cell recorded as an overflow cell).
  std::uniform_int_distribution<unsigned> wide(0, 1000);
  // Round 3's box is inverted (its lower side ~100 cells above its upper side) and overlaps the cells.
  const unsigned margins[] = {0, 0, 100, 550};
  for (std::size_t round = 0; round < std::size(margins); ++round) {
    Evidence ev;
    for (int i = 0; i < 2000; ++i) {
      const Key k{kC - 500 + wide(rng_), kC - 500 + wide(rng_), kC - 500 + wide(rng_)};
      ((rng_() % 3) == 0 ? ev.hit : ev.free).insert(k);
    }
    applyAndCompare(ev, "scattered cells, round " + std::to_string(round), margins[round]);
  }
}

// Cells this map has itself brought to the lower clamp are left out of later free-only updates (OctoMap's
// early abort) without reading the tree, and whole blocks with nothing else are skipped. A cell raised by a
// hit must be updated by the next miss again, also where a pruned leaf changes as a whole.
TEST_P(OctreeBatchUpdate, CellsThisMapClampedAreLeftOutUntilAHitRaisesThem) {
  std::uniform_int_distribution<unsigned> x_range(0, 63), yz_range(0, 39);
  std::vector<Key> cells;
  for (int i = 0; i < 4000; ++i)
    cells.push_back({kC + x_range(rng_), kC + yz_range(rng_), kC + yz_range(rng_)});
  // A whole aligned 16^3 block, freed alike: one pruned leaf, updated in place.
  std::vector<Key> cube;
  for (unsigned x = 0; x < 16; ++x)
    for (unsigned y = 0; y < 16; ++y)
      for (unsigned z = 0; z < 16; ++z) cube.push_back({kC + 128 + x, kC + y, kC + z});
  auto round = [&](const std::string& what, auto&& hit_cell, auto&& hit_cube) {
    Evidence ev;
    for (const Key& k : cells) (hit_cell(k) ? ev.hit : ev.free).insert(k);
    for (const Key& k : cube) (hit_cube(k) ? ev.hit : ev.free).insert(k);
    applyAndCompare(ev, what);
  };
  const auto none = [](const Key&) { return false; };
  // Six rounds of misses: OctoMap's defaults clamp a cell after five.
  for (int r = 0; r < 6; ++r) round("misses, round " + std::to_string(r), none, none);
  const std::size_t known = map_.cellsKnownAtMin();
  EXPECT_GE(known, 4096u) << "the clamped cells should be known";
  // Hits on every third cell and on the whole cube (alike: the leaf stays one), then misses everywhere:
  // the raised cells must take the misses.
  const auto every_third = [](const Key& k) { return (k[0] + k[1] + k[2]) % 3 == 0; };
  const auto all = [](const Key&) { return true; };
  round("hits on a third of the cells and on the cube", every_third, all);
  EXPECT_LT(map_.cellsKnownAtMin(), known);
  round("misses after the hits", none, none);
  round("misses again", none, none);
  // A hit on one cell of the cube: the leaf expands, then misses.
  round("one hit in the cube", none, [&](const Key& k) { return k == cube[1234]; });
  round("misses after it", none, none);
  // Loading a tree (mutableTree) forgets what was known.
  map_.mutableTree();
  EXPECT_EQ(map_.cellsKnownAtMin(), 0u);
  round("misses after the tree was handed out", none, none);
}

INSTANTIATE_TEST_SUITE_P(Threads, OctreeBatchUpdate, ::testing::Values(1, 2, 3),
                         [](const auto& info) { return std::to_string(info.param) + "Threads"; });

}  // namespace
}  // namespace densemap::map
