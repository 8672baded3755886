#include "densemap/map/octree_map.h"

#include <algorithm>
#include <array>
#include <bit>
#include <iterator>
#include <vector>

#include <omp.h>

namespace densemap::map {

namespace {

using geometry::kKeyDepth;

/// OctoMap's computeChildIdx.
inline unsigned childIndex(const VoxelKey& k, unsigned level) {
  return ((k[0] >> level) & 1u) | (((k[1] >> level) & 1u) << 1) | (((k[2] >> level) & 1u) << 2);
}

/// Interleaves the key bits so that sorting by the code visits OctoMap's children in index order.
inline std::uint64_t mortonCode(const VoxelKey& k) {
  auto spread = [](std::uint64_t v) {
    v &= 0xFFFF;
    v = (v | (v << 16)) & 0x0000FF0000FFULL;
    v = (v | (v << 8)) & 0x00F00F00F00FULL;
    v = (v | (v << 4)) & 0x0C30C30C30C3ULL;
    v = (v | (v << 2)) & 0x249249249249ULL;
    return v;
  };
  return spread(k[0]) | (spread(k[1]) << 1) | (spread(k[2]) << 2);
}

float scaled(std::uint32_t n, float l) { return n == 1 ? l : static_cast<float>(n) * l; }

}  // namespace

using Entry = OctreeMap::Entry;

namespace {

/// Writes a block's cells with evidence, with their counts, to `out`. Voxel indices are Morton ranks within
/// the block, so index order is OctoMap's child order. `at_min` (optional): leaves out the free-only cells
/// it marks, whose update is one of OctoMap's early aborts.
template <class Out>
void listCells(const ScanEvidence& evidence, const EvidenceBlock& block, Out out,
               const BitPlane* at_min = nullptr) {
  block.forEachEvidenceVoxel([&](int v) {
    const auto [nf, nh] = evidence.counts(block, v);
    if (at_min != nullptr && nh == 0 && at_min->test(v)) return;
    *out++ = Entry{block.voxelKey(v), nf, nh};
  });
}

/// True when a block holds a cell that at_min does not exempt: a hit, or a free mark on a cell not known to
/// be at the lower clamp.
bool needsUpdate(const EvidenceBlock& block, const BitPlane& at_min) {
  std::uint64_t any = 0;
  for (std::size_t w = 0; w < block.free.words.size(); ++w)
    any |= block.hit.words[w] | (block.free.words[w] & ~at_min.words[w]);
  return any != 0;
}

/// Records a cell's new value in its block's at-min plane.
inline void noteValue(BitPlane* at_min, const VoxelKey& key, float value, const LogOdds& lo) {
  if (at_min == nullptr) return;
  if (value <= lo.min) {
    at_min->set(voxelIndexInBlock(key));
  } else {
    at_min->reset(voxelIndexInBlock(key));
  }
}

}  // namespace

/// Applies a Morton-sorted batch of cell updates in one depth-first pass. Mirrors
/// OccupancyOcTreeBase::updateNode/updateNodeRecurs (lazy_eval = false) for each cell: early abort on a
/// clamped cell, expansion of pruned nodes, creation of unknown nodes, then prune-or-max on the way up.
/// Levels above kSplitDepth are walked serially; the subtrees below are independent and are updated in
/// parallel, each thread creating and deleting nodes through its own empty OcTree (a node factory whose
/// counter is added to the real tree at the end), so no OctoMap state is shared between threads.
class BatchTreeUpdater {
 public:
  // Subtrees of 16^3 voxels: enough tasks per scan to balance two or more threads.
  static constexpr unsigned kSplitDepth = 12;
  static_assert(kKeyDepth - kSplitDepth == kBlockShift, "an evidence block is one subtree at kSplitDepth");

  /// `factories`: empty OcTrees reused across scans as per-thread node factories (an OcTree allocates a
  /// large ray buffer when constructed, so they are kept by the map).
  BatchTreeUpdater(CountedOcTree& tree, const LogOdds& lo,
                   std::vector<std::unique_ptr<octomap::OcTree>>& factories)
      : tree_(tree), lo_(lo), factories_(factories) {}

  void run(std::vector<Entry>& entries) {
    if (entries.empty()) return;
    std::size_t start = 0;
    if (tree_.getRoot() == nullptr) {
      // Let OctoMap create the root through its own code path with the first cell.
      const Entry& e = entries.front();
      const octomap::OcTreeKey k(e.key[0], e.key[1], e.key[2]);
      if (e.n_free > 0) tree_.updateNode(k, scaled(e.n_free, lo_.miss), false);
      if (e.n_hit > 0) tree_.updateNode(k, scaled(e.n_hit, lo_.hit), false);
      start = 1;
    }
    if (start == entries.size()) return;
    tasks_.clear();
    upper_.clear();
    // Serial top: expand/create down to kSplitDepth, remembering the subtrees and the upper nodes.
    descend(tree_, tree_.getRoot(), false, 0, entries.data() + start, entries.data() + entries.size(), true);
    runTasks(nullptr, nullptr);
  }

  /// The same update for evidence blocks (Morton-sorted, each with evidence) when the tree has a root. An
  /// evidence block is exactly one subtree at kSplitDepth, so the serial top follows one key per block and
  /// each parallel task lists its own block's cells (into `scratch`, one list per thread, small enough to
  /// stay in cache) instead of a serial pass listing every cell first. Where the top meets a pruned leaf
  /// above kSplitDepth, OctoMap's early abort needs every cell below it: those blocks' cells are listed
  /// into `listed` and their whole subtree becomes one task.
  void runByBlock(const std::vector<OctreeMap::BlockToApply>& blocks, const ScanEvidence& evidence,
                  std::vector<Entry>& listed, std::vector<std::vector<Entry>>& scratch) {
    if (blocks.empty()) return;
    tasks_.clear();
    upper_.clear();
    listed.clear();
    evidence_ = &evidence;
    descendBlocks(tree_.getRoot(), false, 0, blocks.data(), blocks.data() + blocks.size(), listed);
    while (scratch.size() < static_cast<std::size_t>(omp_get_max_threads()))
      scratch.emplace_back().reserve(kBlockVoxels);
    runTasks(&listed, &scratch);
  }

 private:
  using BlockRef = OctreeMap::BlockToApply;

  /// A subtree to update: its cells are [begin, end) of the entries, or (by-block runs) `block`'s cells,
  /// or [first, last) of the listed entries.
  struct Task {
    octomap::OcTreeNode* node;
    bool just_created;
    unsigned depth;
    Entry* begin = nullptr;
    Entry* end = nullptr;
    const EvidenceBlock* block = nullptr;
    BitPlane* at_min = nullptr;  // the block's at-min plane (by-block tasks of one block)
    std::size_t first = 0, last = 0;
  };

  /// Runs the tasks in parallel, each thread creating and deleting nodes through its own factory, then
  /// adds the factories' node counts to the tree and finishes the upper nodes.
  void runTasks(std::vector<Entry>* listed, std::vector<std::vector<Entry>>* scratch) {
    const auto threads = static_cast<std::size_t>(omp_get_max_threads());
    auto& factories = factories_;
    while (factories.size() < threads)
      factories.push_back(std::make_unique<octomap::OcTree>(tree_.getResolution()));
    std::vector<std::size_t> before(factories.size());
    for (std::size_t t = 0; t < factories.size(); ++t) before[t] = factories[t]->size();
#pragma omp parallel for schedule(dynamic, 1)
    for (std::size_t i = 0; i < tasks_.size(); ++i) {
      const auto thread = static_cast<std::size_t>(omp_get_thread_num());
      Task& t = tasks_[i];
      if (t.block != nullptr) {
        std::vector<Entry>& list = (*scratch)[thread];
        list.clear();
        listCells(*evidence_, *t.block, std::back_inserter(list), t.at_min);
        t.begin = list.data();
        t.end = list.data() + list.size();
      } else if (listed != nullptr) {
        t.begin = listed->data() + t.first;
        t.end = listed->data() + t.last;
      }
      if (t.begin != t.end)
        descend(*factories[thread], t.node, t.just_created, t.depth, t.begin, t.end, false, t.at_min);
    }
    // Node count changes made through each factory (unsigned wrap-around handles net deletions).
    for (std::size_t t = 0; t < factories.size(); ++t) tree_.addToNodeCount(factories[t]->size() - before[t]);
    // Serial bottom-up finish of the upper nodes (post-order, as recorded).
    for (octomap::OcTreeNode* n : upper_)
      if (!tree_.pruneNode(n)) n->updateOccupancyChildren();
  }

  /// The serial top of a by-block run: creates the nodes down to kSplitDepth along the blocks' keys and
  /// records one task per block, the upper nodes in post-order, and one task for the whole subtree of a
  /// pruned leaf met on the way (as descend() would handle it, with its cells listed).
  void descendBlocks(octomap::OcTreeNode* node, bool just_created, unsigned depth, const BlockRef* b,
                     const BlockRef* e, std::vector<Entry>& listed) {
    if (depth == kSplitDepth) {  // one block: blocks are distinct and aligned to the subtrees here
      tasks_.push_back({.node = node,
                        .just_created = just_created,
                        .depth = depth,
                        .block = b->evidence,
                        .at_min = b->at_min});
      return;
    }
    if (!just_created && !tree_.nodeHasChildren(node)) {
      // Listed in full and not tracked: the blocks' at-min planes are forgotten.
      Task t{.node = node, .just_created = false, .depth = depth, .first = listed.size()};
      for (const BlockRef* it = b; it != e; ++it) {
        listCells(*evidence_, *it->evidence, std::back_inserter(listed));
        it->at_min->clear();
      }
      t.last = listed.size();
      tasks_.push_back(t);
      return;
    }
    const unsigned level = kKeyDepth - 1 - depth;
    for (const BlockRef* it = b; it != e;) {
      const unsigned pos = childIndex(it->evidence->base, level);
      const BlockRef* run_end = it + 1;
      while (run_end != e && childIndex(run_end->evidence->base, level) == pos) ++run_end;
      bool created = false;
      if (!tree_.nodeChildExists(node, pos)) {
        tree_.createNodeChild(node, pos);
        created = true;
      }
      descendBlocks(tree_.getNodeChild(node, pos), created, depth + 1, it, run_end, listed);
      it = run_end;
    }
    upper_.push_back(node);  // post-order: children (and their tasks) are recorded before the parent
  }

  /// True when the entries (distinct keys, all inside the node at `depth`) cover every cell of that node
  /// and carry the same counts, so every cell ends with the same value.
  static bool updatesEveryCellAlike(const Entry* b, const Entry* e, unsigned depth) {
    const auto cells = std::size_t{1} << (3 * (kKeyDepth - depth));
    return static_cast<std::size_t>(e - b) == cells && std::all_of(b + 1, e, [&](const Entry& x) {
             return x.n_free == b->n_free && x.n_hit == b->n_hit;
           });
  }

  /// `factory` creates and deletes nodes (and counts them); `top` records tasks at kSplitDepth and defers
  /// the upper nodes' prune-or-max to the end instead of doing it on the way up.
  void descend(octomap::OcTree& factory, octomap::OcTreeNode* node, bool just_created, unsigned depth,
               Entry* b, Entry* e, bool top, BitPlane* at_min = nullptr) {
    if (depth == kKeyDepth) {
      const float v = applyCellUpdate(node->getLogOdds(), b->n_free, b->n_hit, lo_);
      node->setLogOdds(v);
      noteValue(at_min, b->key, v, lo_);
      return;
    }
    if (!just_created && !factory.nodeHasChildren(node)) {
      // A pruned leaf: OctoMap's early abort skips the cells it already clamps; expand only for the rest.
      const float v = node->getLogOdds();
      e = std::remove_if(b, e, [&](const Entry& x) {
        if (!isNoOpUpdate(true, v, x.n_free, x.n_hit, lo_)) return false;
        noteValue(at_min, x.key, v, lo_);
        return true;
      });
      if (e == b) return;
      if (updatesEveryCellAlike(b, e, depth)) {
        // OctoMap would expand this leaf, give every cell the same new value and prune the children back
        // into it on the way up: the same leaf with that value, and no node allocated or freed.
        const float nv = applyCellUpdate(v, b->n_free, b->n_hit, lo_);
        node->setLogOdds(nv);
        for (const Entry* x = b; x != e; ++x) noteValue(at_min, x->key, nv, lo_);
        return;
      }
      factory.expandNode(node);
    }
    if (top && depth == kSplitDepth) {
      tasks_.push_back({.node = node, .just_created = just_created, .depth = depth, .begin = b, .end = e});
      return;
    }
    const unsigned level = kKeyDepth - 1 - depth;
    for (Entry* it = b; it != e;) {
      const unsigned pos = childIndex(it->key, level);
      // Entries are in Morton order, so each child's entries are one run; near the root the runs are long
      // and a binary search finds their ends without reading every entry at every level.
      Entry* run_end;
      if (e - it > 64) {
        run_end =
            std::partition_point(it + 1, e, [&](const Entry& x) { return childIndex(x.key, level) == pos; });
      } else {
        run_end = it + 1;
        while (run_end != e && childIndex(run_end->key, level) == pos) ++run_end;
      }
      bool created = false;
      if (!factory.nodeChildExists(node, pos)) {
        factory.createNodeChild(node, pos);
        created = true;
      }
      descend(factory, factory.getNodeChild(node, pos), created, depth + 1, it, run_end, top, at_min);
      it = run_end;
    }
    if (top) {
      upper_.push_back(node);  // post-order: children (and their tasks) are recorded before the parent
    } else if (!factory.pruneNode(node)) {
      node->updateOccupancyChildren();
    }
  }

  CountedOcTree& tree_;
  const LogOdds& lo_;
  std::vector<std::unique_ptr<octomap::OcTree>>& factories_;
  const ScanEvidence* evidence_ = nullptr;  // by-block runs
  std::vector<Task> tasks_;
  std::vector<octomap::OcTreeNode*> upper_;
};

template <class Tree>
void OctreeMap::configure(Tree& tree, const OccupancyParams& params) {
  tree.setProbHit(params.prob_hit);
  tree.setProbMiss(params.prob_miss);
  tree.setClampingThresMin(params.clamp_min);
  tree.setClampingThresMax(params.clamp_max);
  tree.setOccupancyThres(params.occupied_threshold);
}

std::unique_ptr<octomap::OcTree> OctreeMap::makeTree(double resolution, const OccupancyParams& params) {
  auto tree = std::make_unique<octomap::OcTree>(resolution);
  configure(*tree, params);
  return tree;
}

OctreeMap::OctreeMap(double resolution, const OccupancyParams& params)
    : OccupancyMap(resolution, params), tree_(std::make_unique<CountedOcTree>(resolution)) {
  configure(*tree_, params);
}

std::unique_ptr<OccupancyMap> OctreeMap::clone() const {
  auto copy = std::make_unique<OctreeMap>(resolution(), params_);
  copy->tree_ = std::make_unique<CountedOcTree>(*tree_);  // OcTree's copy constructor copies node for node
  return copy;
}

void OctreeMap::apply(const ScanEvidence& evidence) {
  // Blocks are aligned subtrees: sort blocks by Morton code, then list each block's cells in index order
  // (Morton order within the block), which sorts every cell without a full sort.
  auto& blocks = blocks_;
  blocks.clear();
  if (tree_->getRoot() != nullptr && evidence.overflowCount() == 0) {
    // By block, leaving out what at_min_ shows to be early aborts (whole blocks where nothing else is).
    evidence.forEachBlock([&](const EvidenceBlock& b) {
      if (!b.hasEvidence()) return;  // a block may hold region marks only
      BitPlane& at_min = at_min_.try_emplace(b.base.packed()).first->second;  // zeroed when new
      if (needsUpdate(b, at_min)) blocks.push_back({mortonCode(b.base), &b, &at_min});
    });
    std::sort(blocks.begin(), blocks.end(), [](const auto& a, const auto& b) { return a.morton < b.morton; });
    BatchTreeUpdater(*tree_, log_odds_, factories_).runByBlock(blocks, evidence, entries_, task_entries_);
    // Planes only for blocks with a cell at the lower clamp (a block seen once holds none).
    for (const BlockToApply& b : blocks)
      if (!b.at_min->any()) at_min_.erase(b.evidence->base.packed());
    return;
  }
  // The cell-by-cell pass below does not track at_min_.
  at_min_.clear();
  evidence.forEachBlock([&](const EvidenceBlock& b) {
    if (b.hasEvidence()) blocks.push_back({mortonCode(b.base), &b, nullptr});  // may hold region marks only
  });
  std::sort(blocks.begin(), blocks.end(), [](const auto& a, const auto& b) { return a.morton < b.morton; });
  // An empty tree (its root is made by OctoMap's own updateNode) or cells outside the evidence box: every
  // cell listed first, in Morton order. Each block's cells go to their own slice of the list (popcount
  // prefix sums), filled in parallel.
  auto& entries = entries_;
  std::vector<std::size_t>& offset = offsets_;
  offset.assign(blocks.size() + 1, 0);
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    std::size_t n = 0;
    const EvidenceBlock& b = *blocks[i].evidence;
    for (std::size_t w = 0; w < b.free.words.size(); ++w)
      n += static_cast<std::size_t>(std::popcount(b.free.words[w] | b.hit.words[w]));
    offset[i + 1] = n;
  }
  for (std::size_t i = 0; i < blocks.size(); ++i) offset[i + 1] += offset[i];
  entries.resize(offset.back());
#pragma omp parallel for schedule(dynamic, 16)
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    listCells(evidence, *blocks[i].evidence, entries.begin() + static_cast<std::ptrdiff_t>(offset[i]));
  }
  if (evidence.overflowCount() > 0) {
    evidence.forEachOverflowCell([&](const VoxelKey& k, std::uint32_t nf, std::uint32_t nh) {
      entries.push_back({k, nf, nh});
    });
    std::sort(entries.begin(), entries.end(),
              [](const Entry& a, const Entry& b) { return mortonCode(a.key) < mortonCode(b.key); });
  }
  BatchTreeUpdater(*tree_, log_odds_, factories_).run(entries);
}

std::optional<float> OctreeMap::logOdds(const VoxelKey& key) const {
  const octomap::OcTreeNode* n = tree_->search(octomap::OcTreeKey(key[0], key[1], key[2]));
  if (n == nullptr) return std::nullopt;
  return n->getLogOdds();
}

bool OctreeMap::isFullyFree(const VoxelKey& key) const {
  const octomap::OcTreeNode* n = tree_->search(octomap::OcTreeKey(key[0], key[1], key[2]));
  return n != nullptr && n->getLogOdds() <= log_odds_.min;
}

std::size_t OctreeMap::knownCells() const {
  std::size_t n = 0;
  for (auto it = tree_->begin_leafs(), end = tree_->end_leafs(); it != end; ++it) {
    const std::size_t side = std::size_t{1} << (kKeyDepth - it.getDepth());
    n += side * side * side;
  }
  return n;
}

std::size_t OctreeMap::cellsKnownAtMin() const {
  std::size_t n = 0;
  for (const auto& [id, plane] : at_min_)
    for (const std::uint64_t w : plane.words) n += static_cast<std::size_t>(std::popcount(w));
  return n;
}

std::size_t OctreeMap::memoryBytes() const {
  // at_min_: a plane per block plus the hash map's node and bucket (about four words).
  return tree_->memoryUsage() + at_min_.size() * (sizeof(BitPlane) + 4 * sizeof(void*));
}

void OctreeMap::forEachCell(const std::function<void(const VoxelKey&, float)>& f) const {
  for (auto it = tree_->begin_leafs(), end = tree_->end_leafs(); it != end; ++it) {
    const octomap::OcTreeKey base = it.getIndexKey();
    const unsigned side = 1u << (kKeyDepth - it.getDepth());
    const float v = it->getLogOdds();
    for (unsigned x = 0; x < side; ++x)
      for (unsigned y = 0; y < side; ++y)
        for (unsigned z = 0; z < side; ++z)
          f(VoxelKey{{static_cast<geometry::KeyCoord>(base[0] + x),
                      static_cast<geometry::KeyCoord>(base[1] + y),
                      static_cast<geometry::KeyCoord>(base[2] + z)}},
            v);
  }
}

void OctreeMap::forEachCellInBox(const VoxelKey& lo, const VoxelKey& hi,
                                 const std::function<void(const VoxelKey&, float)>& f) const {
  const octomap::OcTreeKey kmin(lo[0], lo[1], lo[2]), kmax(hi[0], hi[1], hi[2]);
  for (auto it = tree_->begin_leafs_bbx(kmin, kmax), end = tree_->end_leafs_bbx(); it != end; ++it) {
    const octomap::OcTreeKey base = it.getIndexKey();
    const unsigned side = 1u << (kKeyDepth - it.getDepth());
    const float v = it->getLogOdds();
    for (unsigned x = 0; x < side; ++x)
      for (unsigned y = 0; y < side; ++y)
        for (unsigned z = 0; z < side; ++z) {
          const VoxelKey k{{static_cast<geometry::KeyCoord>(base[0] + x),
                            static_cast<geometry::KeyCoord>(base[1] + y),
                            static_cast<geometry::KeyCoord>(base[2] + z)}};
          if (inBox(k, lo, hi)) f(k, v);
        }
  }
}

namespace {
// octomap keeps a node's child array protected (friend: OcTreeBaseImpl only); a pointer to the member
// named through a derived class is the standard-conforming way to reach it.
struct ChildArrayAccess : octomap::OcTreeNode {
  static constexpr auto member() { return &ChildArrayAccess::children; }
};
}  // namespace

std::size_t CountedOcTree::countCells(const octomap::OcTreeNode* node, unsigned depth) const {
  if (!nodeHasChildren(node)) {
    const std::size_t side = std::size_t{1} << (kKeyDepth - depth);
    return side * side * side;
  }
  std::size_t n = 0;
  for (unsigned i = 0; i < 8; ++i) {
    if (nodeChildExists(node, i)) n += countCells(getNodeChild(node, i), depth + 1);
  }
  return n;
}

std::size_t CountedOcTree::eraseRecurs(octomap::OcTreeNode* node, unsigned depth,
                                       const octomap::OcTreeKey& base, const octomap::OcTreeKey& lo,
                                       const octomap::OcTreeKey& hi, bool& emptied) {
  const unsigned half = 1u << (kKeyDepth - depth - 1);
  if (!nodeHasChildren(node)) expandNode(node);  // a pruned leaf crossing the box
  octomap::AbstractOcTreeNode**& children = node->*ChildArrayAccess::member();
  std::size_t erased = 0;
  for (unsigned i = 0; i < 8; ++i) {
    if (children[i] == nullptr) continue;
    octomap::OcTreeKey cb = base;
    bool inside = true, disjoint = false;
    for (unsigned a = 0; a < 3; ++a) {
      cb[a] = static_cast<octomap::key_type>(base[a] + ((i >> a) & 1u) * half);
      const unsigned c_lo = cb[a], c_hi = cb[a] + half - 1;
      inside &= c_lo >= lo[a] && c_hi <= hi[a];
      disjoint |= c_hi < lo[a] || c_lo > hi[a];
    }
    if (disjoint) continue;
    auto* child = static_cast<octomap::OcTreeNode*>(children[i]);
    bool child_emptied = inside;
    if (inside) {
      erased += countCells(child, depth + 1);
    } else {
      erased += eraseRecurs(child, depth + 1, cb, lo, hi, child_emptied);
    }
    if (child_emptied) {
      deleteNodeRecurs(child);  // frees the whole subtree, child arrays included
      children[i] = nullptr;
    }
  }
  emptied = !nodeHasChildren(node);
  if (emptied) {
    delete[] children;
    children = nullptr;
  } else {
    node->updateOccupancyChildren();
  }
  return erased;
}

std::size_t CountedOcTree::eraseBox(const octomap::OcTreeKey& lo, const octomap::OcTreeKey& hi) {
  if (root == nullptr) return 0;
  bool emptied = false;
  const std::size_t erased = eraseRecurs(root, 0, octomap::OcTreeKey(0, 0, 0), lo, hi, emptied);
  if (emptied) {
    deleteNodeRecurs(root);
    root = nullptr;
  }
  tree_size = root == nullptr ? 0 : calcNumNodes();
  size_changed = true;
  return erased;
}

bool identicalTrees(const octomap::OcTree& a, const octomap::OcTree& b, std::string* why) {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  if (a.size() != b.size())
    return fail("node counts differ: " + std::to_string(a.size()) + " vs " + std::to_string(b.size()));
  if (a.getResolution() != b.getResolution()) return fail("resolutions differ");
  auto ia = a.begin_tree(), ea = a.end_tree();
  auto ib = b.begin_tree(), eb = b.end_tree();
  std::size_t i = 0;
  for (; ia != ea && ib != eb; ++ia, ++ib, ++i) {
    if (ia.getDepth() != ib.getDepth() || !(ia.getKey() == ib.getKey()) || ia.isLeaf() != ib.isLeaf())
      return fail("shape differs at node " + std::to_string(i));
    if (std::bit_cast<std::uint32_t>(ia->getLogOdds()) != std::bit_cast<std::uint32_t>(ib->getLogOdds()))
      return fail("log-odds differ at node " + std::to_string(i) + " depth " + std::to_string(ia.getDepth()) +
                  ": " + std::to_string(ia->getLogOdds()) + " vs " + std::to_string(ib->getLogOdds()));
  }
  if ((ia == ea) != (ib == eb)) return fail("trees have different lengths");
  return true;
}

}  // namespace densemap::map
