// Walks a scan's rays and records their free cells in the scan's evidence: the hot loop of every method.
#pragma once

#include <cstdint>
#include <vector>

#include "densemap/map/occupancy_map.h"
#include "densemap/map/scan_evidence.h"
#include "densemap/update/super_ray_generator.h"

namespace densemap::update {

struct TraceOptions {
  bool counting = false;        ///< counting semantics (add weights) instead of batch (mark once)
  bool backward = false;        ///< walk from the endpoint toward the sensor (needed by the culling region)
  bool region = false;          ///< the evidence holds a non-empty region to stop at
  bool stop_at_closed = false;  ///< stop at the in-scan closed region instead of the culling region
  /// Which rays to walk: all, a sample of about 1 in `sample_every` (chosen by endpoint), or the others.
  enum class Subset { kAll, kSample, kRest } subset = Subset::kAll;
  std::size_t sample_every = 8;
  bool count_unnecessary = false;
  /// conv.toKey(rays[i].end) for i < end_keys->size(), where the caller has them already (the engine's
  /// preparation converts every endpoint): the walks then skip converting them again. Those rays end at the
  /// scan's endpoints: the forward pair walks (batch semantics, all rays) mark their cells hit too.
  const std::vector<geometry::VoxelKey>* end_keys = nullptr;
};

struct TraceCounters {
  std::uint64_t traversed = 0;    ///< cell visits
  std::uint64_t fallbacks = 0;    ///< backward walks finished forward because of a rounding tie
  std::uint64_t unnecessary = 0;  ///< visits of cells already fully free (when counted)
  /// Batch semantics, forward walks of endpoints with known keys: the walks marked each endpoint's cell hit
  /// themselves (where they end, with the cell's block at hand), so the caller must not mark them again.
  bool hits_marked = false;
  std::uint64_t hit_cells = 0;  ///< endpoints that were the first of this scan in their cell (inside the box)
  std::uint64_t shared_walks = 0;  ///< summed walk lengths (cells) of the other endpoints
};

/// Records the free cells of every ray from `origin` to `rays[i].end` (excluding the end cell) with weight
/// `rays[i].weight`: forward (baseline, OctoMap's order) or backward from the endpoint, stopping on entering
/// the culling region held in the evidence.
TraceCounters traceRays(const map::OccupancyMap& map, map::ScanEvidence& evidence,
                        const geometry::Vec3f& origin, const std::vector<SuperRay>& rays,
                        const TraceOptions& options);
/// The same for rays of weight 1 ending at `ends`.
TraceCounters traceRays(const map::OccupancyMap& map, map::ScanEvidence& evidence,
                        const geometry::Vec3f& origin, const std::vector<geometry::Vec3f>& ends,
                        const TraceOptions& options);

}  // namespace densemap::update
