// The one place that turns a backend name into an occupancy map (every program and the server use it).
#pragma once

#include <memory>
#include <string>

#include "densemap/map/decay.h"
#include "densemap/map/occupancy_map.h"
#include "densemap/map/occupancy_params.h"

namespace densemap::map {

struct MapOptions {
  std::string backend = "grid";  ///< "grid" (hashed dense blocks, fastest) or "octree" (OctoMap's OcTree)
  double resolution = 0.2;       ///< voxel edge in metres
  OccupancyParams params{};      ///< OctoMap's sensor model defaults
  DecayOptions decay{};          ///< off by default; grid backend only (its time is kept per block)
};

/// Throws std::invalid_argument naming the option that is wrong.
std::unique_ptr<OccupancyMap> makeMap(const MapOptions& options);

}  // namespace densemap::map
