#include "densemap/map/map_projection.h"

#include <algorithm>
#include <limits>

namespace densemap::map {

ProjectedGrid projectToGrid(const OccupancyMap& map, double min_z, double max_z) {
  const auto& conv = map.converter();
  const float threshold = OccupancyParams::logOdds(map.params().occupied_threshold);
  struct Column {
    std::uint32_t x, y;
    bool occupied;
  };
  std::vector<Column> columns;
  std::uint32_t lo_x = std::numeric_limits<std::uint32_t>::max(), lo_y = lo_x, hi_x = 0, hi_y = 0;
  map.forEachCell([&](const VoxelKey& k, float v) {
    const double z = conv.toCoord(k).z();
    if (z < min_z || z > max_z) return;
    columns.push_back({k[0], k[1], v >= threshold});
    lo_x = std::min<std::uint32_t>(lo_x, k[0]);
    lo_y = std::min<std::uint32_t>(lo_y, k[1]);
    hi_x = std::max<std::uint32_t>(hi_x, k[0]);
    hi_y = std::max<std::uint32_t>(hi_y, k[1]);
  });
  ProjectedGrid g;
  g.resolution = map.resolution();
  if (columns.empty()) return g;
  g.width = hi_x - lo_x + 1;
  g.height = hi_y - lo_y + 1;
  VoxelKey corner;
  corner[0] = static_cast<geometry::KeyCoord>(lo_x);
  corner[1] = static_cast<geometry::KeyCoord>(lo_y);
  const geometry::Vec3f c = conv.toCoord(corner);
  g.origin_x = c.x() - g.resolution / 2;
  g.origin_y = c.y() - g.resolution / 2;
  g.cells.assign(std::size_t{g.width} * g.height, -1);
  for (const Column& col : columns) {
    std::int8_t& cell = g.cells[std::size_t{col.y - lo_y} * g.width + (col.x - lo_x)];
    if (col.occupied)
      cell = 100;
    else if (cell != 100)
      cell = 0;
  }
  return g;
}

std::vector<geometry::Vec3f> occupiedCentres(const OccupancyMap& map) {
  const float threshold = OccupancyParams::logOdds(map.params().occupied_threshold);
  std::vector<std::pair<VoxelKey, geometry::Vec3f>> cells;
  map.forEachCell([&](const VoxelKey& k, float v) {
    if (v >= threshold) cells.emplace_back(k, map.converter().toCoord(k));
  });
  std::sort(cells.begin(), cells.end(), [](const auto& a, const auto& b) { return a.first.k < b.first.k; });
  std::vector<geometry::Vec3f> out;
  out.reserve(cells.size());
  for (const auto& [k, c] : cells) out.push_back(c);
  return out;
}

}  // namespace densemap::map
