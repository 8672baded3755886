// The voxel keys an axis-aligned box covers (box queries and clear-box commands share it).
#pragma once

#include <utility>

#include "densemap/geometry/voxel_key.h"

namespace densemap::server {

/// The key range of the box, clamped to the map's key range. Throws RequestError (kInvalidArgument) for
/// non-finite or inverted corners.
std::pair<geometry::VoxelKey, geometry::VoxelKey> boxKeys(const geometry::KeyConverter& conv,
                                                          const geometry::Vec3f& lo,
                                                          const geometry::Vec3f& hi);

}  // namespace densemap::server
