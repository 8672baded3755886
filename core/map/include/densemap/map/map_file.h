// Saving maps as OctoMap files (.bt: binary max-likelihood, .ot: full log-odds), whatever the backend, so
// they open in OctoMap's tools (octovis).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include <octomap/OcTree.h>

#include "densemap/map/map_factory.h"
#include "densemap/map/occupancy_map.h"
#include "densemap/map/octomap_file.h"

namespace densemap::map {

/// An OcTree with the map's cells and sensor model (a copy; the map is not changed).
std::unique_ptr<octomap::OcTree> toOcTree(const OccupancyMap& map);

/// Writes `path` (.bt or .ot, chosen by the extension) through a temporary file renamed into place, so a
/// failed save never leaves a truncated map. Throws std::runtime_error saying what went wrong.
void saveMap(const OccupancyMap& map, const std::string& path);

/// The bytes of `path` saved as .bt (each cell's state) or .ot (full log-odds), chosen by the extension.
std::string encodeMap(const OccupancyMap& map, OctomapFormat format);

/// The tree data an octomap_msgs/Octomap message carries (OctoMap's writeBinaryData for binary, writeData
/// for full: the file's node stream without its header), as octomap_msgs' binaryMapToMsg / fullMapToMsg.
std::string octomapMessageData(const OccupancyMap& map, OctomapFormat format);

struct MapLoadLimits {
  std::size_t max_bytes = std::size_t{4} << 30;  ///< larger files are refused unread
  std::uint64_t max_cells = 512'000'000;         ///< cells after expanding pruned leaves (grid backend)
};

/// A map of `options`' backend and sensor model built from a .bt/.ot file's bytes: from .ot the same
/// log-odds in every cell (octree: node for node); from .bt each cell at the clamping value of its state,
/// as OctoMap keeps it. Throws MapFileError (corrupt file, other resolution, too large).
std::unique_ptr<OccupancyMap> decodeMap(std::string_view bytes, const MapOptions& options,
                                        const MapLoadLimits& limits = {});

}  // namespace densemap::map
