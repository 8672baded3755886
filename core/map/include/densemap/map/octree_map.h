// An occupancy map backed by octomap::OcTree, so maps save as .bt/.ot and open in OctoMap's tools.
// A scan's evidence is applied in one depth-first pass over its cells in Morton order, which yields the
// same tree, node for node and bit for bit, as OctoMap's per-key updateNode calls (same early aborts,
// expansions and pruning, except a pruned leaf whose every cell gets the same update: OctoMap expands it and
// prunes it back, this pass only updates it) while visiting every inner node only once.
#pragma once

#include <memory>
#include <unordered_map>
#include <vector>

#include <octomap/OcTree.h>

#include "densemap/map/occupancy_map.h"
#include "densemap/map/scan_evidence.h"

namespace densemap::map {

/// octomap::OcTree plus access to its node counter, so subtrees can be updated in parallel with per-thread
/// counters that are added back afterwards. Files it writes are plain OcTree files ("OcTree" type).
class CountedOcTree : public octomap::OcTree {
 public:
  using octomap::OcTree::OcTree;
  /// Adds nodes created (or, wrapping, removed) elsewhere to the node count.
  void addToNodeCount(std::size_t delta) {
    tree_size += delta;
    size_changed = true;
  }

  /// Deletes every leaf cell with lo <= key <= hi (pruned leaves crossing the box are expanded first) and
  /// recomputes the inner nodes on the way up; returns the number of finest-resolution cells removed.
  /// (octomap's deleteNode() aborts on its own assertion when a node loses its last child.)
  std::size_t eraseBox(const octomap::OcTreeKey& lo, const octomap::OcTreeKey& hi);

 private:
  std::size_t eraseRecurs(octomap::OcTreeNode* node, unsigned depth, const octomap::OcTreeKey& base,
                          const octomap::OcTreeKey& lo, const octomap::OcTreeKey& hi, bool& emptied);
  std::size_t countCells(const octomap::OcTreeNode* node, unsigned depth) const;
};

class OctreeMap : public OccupancyMap {
 public:
  OctreeMap(double resolution, const OccupancyParams& params = {});

  std::string backendName() const override { return "octree"; }
  void apply(const ScanEvidence& evidence) override;
  std::optional<float> logOdds(const VoxelKey& key) const override;
  bool isFullyFree(const VoxelKey& key) const override;
  std::size_t knownCells() const override;
  std::size_t memoryBytes() const override;
  void forEachCell(const std::function<void(const VoxelKey&, float)>& f) const override;
  void forEachCellInBox(const VoxelKey& lo, const VoxelKey& hi,
                        const std::function<void(const VoxelKey&, float)>& f) const override;
  std::size_t eraseBox(const VoxelKey& lo, const VoxelKey& hi) override {
    at_min_.clear();
    return tree_->eraseBox(octomap::OcTreeKey(lo[0], lo[1], lo[2]), octomap::OcTreeKey(hi[0], hi[1], hi[2]));
  }
  void clear() override {
    at_min_.clear();
    tree_->clear();
  }
  std::unique_ptr<OccupancyMap> clone() const override;

  const octomap::OcTree& tree() const { return *tree_; }
  /// Cells this map knows to be at the lower clamp (see at_min_), for tests and statistics.
  std::size_t cellsKnownAtMin() const;
  /// The tree, to change it (loading a file): the map then forgets which cells it knew to be at the lower
  /// clamp (at_min_).
  octomap::OcTree& mutableTree() {
    at_min_.clear();
    return *tree_;
  }

  /// Builds an OcTree with the same resolution and sensor model (for OctoMap reference runs).
  static std::unique_ptr<octomap::OcTree> makeTree(double resolution, const OccupancyParams& params);
  template <class Tree>
  static void configure(Tree& tree, const OccupancyParams& params);

  /// One cell's evidence, as listed for the depth-first tree update.
  struct Entry {
    VoxelKey key;
    std::uint32_t n_free;
    std::uint32_t n_hit;
  };
  /// An evidence block to apply: its Morton code (the sort key), its evidence and its at_min_ plane.
  struct BlockToApply {
    std::uint64_t morton;
    const EvidenceBlock* evidence;
    BitPlane* at_min;
  };

 private:
  std::unique_ptr<CountedOcTree> tree_;
  std::vector<Entry> entries_;                    // per-scan buffer, kept to avoid reallocating
  std::vector<std::vector<Entry>> task_entries_;  // one block's cells per thread (by-block updates)
  std::vector<BlockToApply> blocks_;
  /// Per 16^3 block (by its base key), cells this map set to the lower clamp itself and has not changed
  /// since. A scan's free-only update of such a cell is one of OctoMap's early aborts (no change anywhere
  /// in the tree), so apply() leaves it out without reading the tree, and skips a block where nothing else
  /// is left. A set bit is always true; a clear bit says nothing. Forgotten (cleared) whenever the tree
  /// may change other than through apply()'s by-block pass.
  std::unordered_map<std::uint64_t, BitPlane> at_min_;
  std::vector<std::size_t> offsets_;
  std::vector<std::unique_ptr<octomap::OcTree>> factories_;  // per-thread node factories for apply()
};

/// Node-for-node comparison of two OcTrees: same shape, same log-odds bits in every node.
bool identicalTrees(const octomap::OcTree& a, const octomap::OcTree& b, std::string* why = nullptr);

}  // namespace densemap::map
