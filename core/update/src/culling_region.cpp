#include "densemap/update/culling_region.h"

#include <deque>

namespace densemap::update {

using geometry::KeyCoord;
using geometry::VoxelKey;
using map::EvidenceBlock;

namespace {

/// Alg. 3's breadth-first search, generic over the admission test, the flag marking membership and the
/// flag marking cells already queued.
template <map::BitPlane EvidenceBlock::*kMember, map::BitPlane EvidenceBlock::*kQueued, class Admit>
CullingRegionStats growRegion(const VoxelKey& o, map::ScanEvidence& ev, Admit&& admit) {
  CullingRegionStats stats;
  ev.noteRegionsUsed();
  // Lines 2-5.
  if (!ev.insideBox(o) || !admit(o)) return stats;
  std::deque<VoxelKey> queue;
  auto insert = [&](const VoxelKey& c) {
    (ev.block(c)->*kMember).set(map::voxelIndexInBlock(c));
    ++stats.cells;
  };
  auto pushNeighbours = [&](const VoxelKey& c) {
    // Neighbours except the test cells: one step away from the origin along each axis.
    for (int a = 0; a < 3; ++a)
      for (int s : {-1, 1}) {
        const int d = static_cast<int>(c[a]) - static_cast<int>(o[a]);
        if ((d > 0 && s < 0) || (d < 0 && s > 0)) continue;  // that is a test cell
        const int v = static_cast<int>(c[a]) + s;
        if (v < 0 || v > 0xFFFF) continue;
        VoxelKey n = c;
        n[a] = static_cast<KeyCoord>(v);
        EvidenceBlock* nb = ev.block(n);
        const int ni = map::voxelIndexInBlock(n);
        if (nb == nullptr || (nb->*kQueued).test(ni)) continue;  // outside the scan's box, or queued already
        (nb->*kQueued).set(ni);
        queue.push_back(n);
      }
  };
  (ev.block(o)->*kQueued).set(map::voxelIndexInBlock(o));
  insert(o);
  pushNeighbours(o);
  // Lines 6-13: FIFO order pops cells by Manhattan distance, so a cell's test cells are settled before it.
  while (!queue.empty()) {
    const VoxelKey c = queue.front();
    queue.pop_front();
    ++stats.tested;
    bool ok = true;
    for (int a = 0; a < 3 && ok; ++a) {
      const int d = static_cast<int>(c[a]) - static_cast<int>(o[a]);
      if (d == 0) continue;
      VoxelKey t = c;
      t[a] = static_cast<KeyCoord>(static_cast<int>(c[a]) - (d > 0 ? 1 : -1));
      const EvidenceBlock* tb = ev.findBlock(t);
      ok = tb != nullptr && (tb->*kMember).test(map::voxelIndexInBlock(t));
    }
    if (!ok || !admit(c)) continue;
    insert(c);
    pushNeighbours(c);
  }
  return stats;
}

}  // namespace

CullingRegionStats CullingRegion::build(const map::OccupancyMap& map, const VoxelKey& o,
                                        map::ScanEvidence& ev) {
  return growRegion<&EvidenceBlock::region, &EvidenceBlock::visited>(
      o, ev, [&](const VoxelKey& c) { return map.isFullyFree(c); });
}

CullingRegionStats CullingRegion::buildClosed(const VoxelKey& o, map::ScanEvidence& ev) {
  return growRegion<&EvidenceBlock::closed, &EvidenceBlock::seen>(o, ev, [&](const VoxelKey& c) {
    const EvidenceBlock* b = ev.findBlock(c);
    const int i = map::voxelIndexInBlock(c);
    return b != nullptr && (b->region.test(i) || b->free.test(i));
  });
}

}  // namespace densemap::update
