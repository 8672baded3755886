#include "densemap/update/culling_region.h"

#include <deque>

namespace densemap::update {

using geometry::KeyCoord;
using geometry::VoxelKey;
using map::EvidenceBlock;

namespace {

bool markVisited(map::ScanEvidence& ev, const VoxelKey& k) {
  EvidenceBlock* b = ev.block(k);
  if (b == nullptr) return false;  // outside the scan's box
  const int i = map::voxelIndexInBlock(k);
  if (EvidenceBlock::testBit(b->visited, i)) return false;
  EvidenceBlock::setBit(b->visited, i);
  return true;
}

}  // namespace

CullingRegionStats CullingRegion::build(const map::OccupancyMap& map, const VoxelKey& o, map::ScanEvidence& ev) {
  CullingRegionStats stats;
  // Alg. 3 lines 2-5.
  if (!ev.insideBox(o) || !map.isFullyFree(o)) return stats;
  std::deque<VoxelKey> queue;
  auto insert = [&](const VoxelKey& c) {
    EvidenceBlock* b = ev.block(c);
    EvidenceBlock::setBit(b->region, map::voxelIndexInBlock(c));
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
        if (markVisited(ev, n)) queue.push_back(n);
      }
  };
  markVisited(ev, o);
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
      ok = ev.inRegion(t);
    }
    if (!ok || !map.isFullyFree(c)) continue;
    insert(c);
    pushNeighbours(c);
  }
  return stats;
}

}  // namespace densemap::update
