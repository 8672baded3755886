// Saving maps as OctoMap files (.bt: binary max-likelihood, .ot: full log-odds), whatever the backend, so
// they open in OctoMap's tools (octovis).
#pragma once

#include <memory>
#include <string>

#include <octomap/OcTree.h>

#include "densemap/map/occupancy_map.h"

namespace densemap::map {

/// An OcTree with the map's cells and sensor model (a copy; the map is not changed).
std::unique_ptr<octomap::OcTree> toOcTree(const OccupancyMap& map);

/// Writes `path` (.bt or .ot, chosen by the extension) through a temporary file renamed into place, so a
/// failed save never leaves a truncated map. Throws std::runtime_error saying what went wrong.
void saveMap(const OccupancyMap& map, const std::string& path);

}  // namespace densemap::map
