// Distances between map blocks and robots, for the rolling windows over the exact map and the dense
// layer: a block leaves memory when its centre is farther than the radius from every robot.
#pragma once

#include <span>

#include "densemap/geometry/voxel_key.h"

namespace densemap::geometry {

/// The key at the centre of a block of 2^shift keys per side (block coordinates: key >> shift).
inline VoxelKey blockCentreKey(const VoxelKey& block, int shift) {
  const int half = (1 << shift) / 2;
  return VoxelKey{{static_cast<KeyCoord>((block[0] << shift) + half),
                   static_cast<KeyCoord>((block[1] << shift) + half),
                   static_cast<KeyCoord>((block[2] << shift) + half)}};
}

/// True when `p` is farther than `radius` from every one of `centres` (true for no centres at all).
inline bool fartherThanAll(const Vec3f& p, std::span<const Vec3f> centres, double radius) {
  const double r2 = radius * radius;
  for (const Vec3f& c : centres)
    if (static_cast<double>((p - c).squaredNorm()) <= r2) return false;
  return true;
}

}  // namespace densemap::geometry
