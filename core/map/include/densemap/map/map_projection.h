// Views of a map that ROS 2 tools read (as octomap_server makes them): a 2D occupancy grid of the cells
// in a height band (Nav2's costmaps read it), and the centres of the occupied cells.
#pragma once

#include <cstdint>
#include <vector>

#include "densemap/map/occupancy_map.h"

namespace densemap::map {

struct ProjectedGrid {
  double resolution = 0;
  double origin_x = 0, origin_y = 0;  ///< the corner of cell (0, 0), in the map frame
  std::uint32_t width = 0, height = 0;
  std::vector<std::int8_t> cells;  ///< row-major from the origin: -1 unknown, 0 free, 100 occupied
};

/// Every known cell whose centre lies in [min_z, max_z], projected onto the xy plane: a column is 100 when
/// any of its cells in the band is occupied, else 0 when one is free, else -1. The grid spans the band's
/// known cells; it is empty (0 x 0) when there are none.
ProjectedGrid projectToGrid(const OccupancyMap& map, double min_z, double max_z);

/// The centres of the cells that read as occupied (log-odds at or above the occupancy threshold, as
/// OctoMap's isNodeOccupied), in key order.
std::vector<geometry::Vec3f> occupiedCentres(const OccupancyMap& map);

}  // namespace densemap::map
