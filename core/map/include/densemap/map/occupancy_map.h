// The interface every occupancy backend implements, so each update method runs on any backend.
#pragma once

#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>

#include "densemap/geometry/voxel_key.h"
#include "densemap/map/occupancy_params.h"
#include "densemap/map/scan_evidence.h"
#include "densemap/map/update_semantics.h"

namespace densemap::map {

class OccupancyMap {
 public:
  OccupancyMap(double resolution, const OccupancyParams& params)
      : converter_(resolution), params_(params), log_odds_(params) {}
  virtual ~OccupancyMap() = default;

  virtual std::string backendName() const = 0;

  /// Applies one scan's evidence (Eq. 2.2 with clamping) under the given semantics' counts.
  virtual void apply(const ScanEvidence& evidence) = 0;

  /// Publishes the map's write of a scan: runs `commit` (which changes what readers see) inside `publish`,
  /// e.g. under an exclusive lock that readers share.
  using Publisher = std::function<void(const std::function<void()>& commit)>;

  /// apply(), for maps read concurrently: work that does not change what readers see (computing the new
  /// cell values) happens before `publish`, so readers are held up only by the final swap. The default
  /// runs the whole apply() inside `publish`.
  virtual void applyPublished(const ScanEvidence& evidence, const Publisher& publish) {
    publish([&] { apply(evidence); });
  }

  /// Log-odds of the cell, or nullopt when it was never observed.
  virtual std::optional<float> logOdds(const VoxelKey& key) const = 0;

  /// logOdds() of many cells at once (query batches): out[i] is the log-odds of keys[i], NaN when the cell
  /// was never observed. The default asks logOdds() per key; GridMap overlaps the lookups' cache misses.
  virtual void logOddsMany(std::span<const VoxelKey> keys, std::span<float> out) const;

  /// True when the cell is known and clamped at the lower bound: free updates cannot change it.
  virtual bool isFullyFree(const VoxelKey& key) const = 0;

  /// Number of known leaf cells at the finest resolution.
  virtual std::size_t knownCells() const = 0;
  virtual std::size_t memoryBytes() const = 0;

  /// Calls f(key, log_odds) for every known cell at the finest resolution (pruned octree leaves are
  /// expanded), in no particular order.
  virtual void forEachCell(const std::function<void(const VoxelKey&, float)>& f) const = 0;

  /// Calls f for every known cell with lo <= key <= hi on every axis (the default filters forEachCell).
  virtual void forEachCellInBox(const VoxelKey& lo, const VoxelKey& hi,
                                const std::function<void(const VoxelKey&, float)>& f) const {
    forEachCell([&](const VoxelKey& k, float v) {
      if (inBox(k, lo, hi)) f(k, v);
    });
  }

  /// Forgets every cell with lo <= key <= hi (they become unknown); returns how many known cells were
  /// removed.
  virtual std::size_t eraseBox(const VoxelKey& lo, const VoxelKey& hi) = 0;

  virtual void clear() = 0;

  /// Map time moves on to `now_s` (seconds; the server uses the scans' receive times, so a journal replay
  /// repeats it). With decay on (decay.h, grid backend only) every whole step relaxes each known cell
  /// toward unknown, inside `publish`. Earlier times are ignored. Returns true when the cells changed.
  virtual bool advanceTime(double now_s, const Publisher& publish) {
    (void)now_s;
    (void)publish;
    return false;
  }
  /// The map time of the last decay step; NaN without decay or before the first time was given.
  virtual double mapTime() const { return std::numeric_limits<double>::quiet_NaN(); }
  /// Restores mapTime() (a snapshot, a loaded map replacing this one): every cell is current at it.
  virtual void setMapTime(double t_s) { (void)t_s; }

  /// A deep copy with the same cells and sensor model (snapshots: a save writes from the copy while the
  /// map goes on changing).
  virtual std::unique_ptr<OccupancyMap> clone() const = 0;

  static bool inBox(const VoxelKey& k, const VoxelKey& lo, const VoxelKey& hi) {
    return k[0] >= lo[0] && k[0] <= hi[0] && k[1] >= lo[1] && k[1] <= hi[1] && k[2] >= lo[2] && k[2] <= hi[2];
  }

  const geometry::KeyConverter& converter() const { return converter_; }
  double resolution() const { return converter_.resolution(); }
  const OccupancyParams& params() const { return params_; }
  const LogOdds& logOddsParams() const { return log_odds_; }

 protected:
  geometry::KeyConverter converter_;
  OccupancyParams params_;
  LogOdds log_odds_;
};

}  // namespace densemap::map
