// How the rays of one scan combine in a cell.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "densemap/map/occupancy_params.h"

namespace densemap::map {

enum class UpdateSemantics {
  /// OctoMap's insertPointCloud: each cell changes at most once per scan, by l_free or l_occ, and a cell
  /// both hit and crossed counts as hit ("occupied wins").
  kBatch,
  /// Sec. 2.3.4: a cell crossed by n_free rays and hit by n_hit rays in one scan gets n_free * l_free,
  /// clamped, then n_hit * l_occ, clamped. Free comes first so skipping fully free cells (culling) is exact.
  kCounting,
};

std::string_view toString(UpdateSemantics s);
std::optional<UpdateSemantics> parseSemantics(std::string_view s);

/// Applies one scan's evidence to a cell value the way OctoMap's updateNode + updateNodeLogOdds do:
/// add, then clamp. A never-observed cell enters with value 0, as a new OctoMap node does.
inline float applyCellUpdate(float value, std::uint32_t n_free, std::uint32_t n_hit, const LogOdds& lo) {
  if (n_free > 0 && !(value <= lo.min)) {
    value += n_free == 1 ? lo.miss : static_cast<float>(n_free) * lo.miss;
    if (value < lo.min) value = lo.min;
    if (value > lo.max) value = lo.max;
  }
  if (n_hit > 0 && !(value >= lo.max)) {
    value += n_hit == 1 ? lo.hit : static_cast<float>(n_hit) * lo.hit;
    if (value < lo.min) value = lo.min;
    if (value > lo.max) value = lo.max;
  }
  return value;
}

/// True when OctoMap's updateNode would return early for every part of this update (the cell is known and
/// already clamped in the direction of each update), so the map, including an octree's shape, is untouched.
inline bool isNoOpUpdate(bool known, float value, std::uint32_t n_free, std::uint32_t n_hit,
                         const LogOdds& lo) {
  if (!known) return false;
  const bool free_noop = n_free == 0 || value <= lo.min;
  const bool hit_noop = n_hit == 0 || value >= lo.max;
  return free_noop && hit_noop;
}

}  // namespace densemap::map
