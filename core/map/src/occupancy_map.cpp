#include "densemap/map/occupancy_map.h"

#include <cmath>
#include <limits>

namespace densemap::map {

void OccupancyMap::logOddsMany(std::span<const VoxelKey> keys, std::span<float> out) const {
  for (std::size_t i = 0; i < keys.size(); ++i)
    out[i] = logOdds(keys[i]).value_or(std::numeric_limits<float>::quiet_NaN());
}

}  // namespace densemap::map
