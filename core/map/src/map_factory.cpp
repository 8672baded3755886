#include "densemap/map/map_factory.h"

#include <stdexcept>

#include "densemap/map/grid_map.h"
#include "densemap/map/octree_map.h"

namespace densemap::map {

std::unique_ptr<OccupancyMap> makeMap(const MapOptions& o) {
  if (const std::string why = o.params.validate(); !why.empty()) throw std::invalid_argument(why);
  if (!(o.resolution > 0.0)) throw std::invalid_argument("the map resolution must be positive");
  if (o.backend == "grid") {
    auto grid = std::make_unique<GridMap>(o.resolution, o.params);
    grid->setDecay(o.decay);
    return grid;
  }
  if (o.backend == "octree") {
    if (o.decay.enabled())
      throw std::invalid_argument(
          "decay needs the grid backend (it keeps time per block); use --backend grid");
    return std::make_unique<OctreeMap>(o.resolution, o.params);
  }
  throw std::invalid_argument("unknown map backend '" + o.backend + "' (use grid or octree)");
}

}  // namespace densemap::map
