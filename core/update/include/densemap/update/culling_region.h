// The culling region of Sec. 2.3.5 (Alg. 3): cells around the sensor from which the rest of any ray toward
// the sensor only crosses fully free cells, where clamping makes free updates no-ops. Rebuilt every scan.
#pragma once

#include <cstdint>

#include "densemap/map/occupancy_map.h"
#include "densemap/map/scan_evidence.h"

namespace densemap::update {

struct CullingRegionStats {
  std::uint64_t cells = 0;   ///< cells in the region
  std::uint64_t tested = 0;  ///< cells popped from the queue
};

class CullingRegion {
 public:
  /// Breadth-first search from the sensor's cell over fully free cells whose test cells (the neighbours one
  /// step closer to the sensor along each axis where they differ) are already inside; limited to the scan's
  /// box in `evidence`, where the membership bits are stored.
  static CullingRegionStats build(const map::OccupancyMap& map, const geometry::VoxelKey& origin_key,
                                  map::ScanEvidence& evidence);

  /// Batch semantics only: the same search (kClosed), admitting cells that are in the culling region or
  /// already marked free by this scan. A ray entering it may stop, as every cell left on its way to the
  /// sensor is either clamped free or already marked, and marking twice changes nothing.
  static CullingRegionStats buildClosed(const geometry::VoxelKey& origin_key, map::ScanEvidence& evidence);
};

}  // namespace densemap::update
