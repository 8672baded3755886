// Integrates scans into an occupancy map with one of four interchangeable methods, all producing the
// same map as the baseline for a given semantics (Ch. 2).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "densemap/geometry/voxel_key.h"
#include "densemap/map/occupancy_map.h"
#include "densemap/map/scan_evidence.h"
#include "densemap/map/update_semantics.h"
#include "densemap/update/method_chooser.h"
#include "densemap/update/super_ray_generator.h"
#include "densemap/update/update_method.h"

namespace densemap::update {

struct UpdateOptions {
  /// kFastest (the default) runs the baseline, or, when the scans could let super rays save enough walking
  /// (MethodChooserOptions::min_saving_to_measure), measures the four and runs the fastest
  /// (update/method_chooser.h); a concrete method forces it.
  UpdateMethod method = UpdateMethod::kFastest;
  MethodChooserOptions chooser{};
  map::UpdateSemantics semantics = map::UpdateSemantics::kBatch;
  /// Rays longer than this are cut there and give no occupied endpoint (OctoMap's maxrange); < 0: unlimited.
  double max_range = -1.0;
  SuperRayOptions super_rays{};
  /// Culling methods, batch semantics: first walk every `closure_sample_every`-th ray, then grow the
  /// culling region (Alg. 3's test) over cells fully free OR already marked free by this scan, and let the
  /// remaining rays stop on entering it. Exact because a batch update marks a cell at most once (our
  /// extension of Sec. 2.3.5 to the scan's own rays).
  bool in_scan_closure = true;
  std::size_t closure_sample_every = 8;
  /// Count traversals of cells that were already fully free (Table 2.3). Costs a map lookup per cell.
  bool count_unnecessary = false;
  /// Count the distinct cells the scan gives evidence and those whose value it changes
  /// (UpdateStats::updated_cells, changed_cells). Costs two map lookups per cell; not in the times.
  bool count_cells = false;
};

struct UpdateStats {
  UpdateMethod method = UpdateMethod::kBaseline;  ///< the method that ran (kFastest's choice)
  std::uint64_t points = 0;                       ///< points given
  std::uint64_t rejected = 0;                     ///< non-finite points or points outside the key range
  std::uint64_t rays = 0;                         ///< traversals started (super rays + single rays)
  std::uint64_t super_rays = 0;                   ///< rays of weight > 1
  std::uint64_t grouped_points = 0;               ///< points represented by those super rays
  std::uint64_t traversed = 0;                    ///< cells visited by all traversals
  std::uint64_t unnecessary = 0;                  ///< visits of already fully free cells (when counted)
  /// Distinct cells given evidence (when counted; the culling methods leave out fully free cells).
  std::uint64_t updated_cells = 0;
  /// Distinct cells whose value the scan changed (when counted): the same for every exact method, and the
  /// floor of its work; traversed / changed_cells is the walks' cost per useful cell.
  std::uint64_t changed_cells = 0;
  std::uint64_t region_cells = 0;  ///< culling region size
  std::uint64_t closed_cells = 0;  ///< in-scan closed region size (batch semantics, culling methods)
  std::uint64_t fallbacks = 0;     ///< backward walks finished forward because of a rounding tie
  /// What kFastest's choice for the next scan rests on: the cells walked per ray (the mean L1 distance from
  /// the sensor's cell to the endpoints' cells) and the distinct endpoint cells (rays with endpoints only).
  double walk_cells_per_ray = 0.0;
  std::uint64_t end_cells = 0;
  /// Walked cells per endpoint that super rays could save: the walks of the endpoints whose cell another
  /// endpoint of the scan already had, per endpoint (dense points are mostly near, with short walks, so
  /// this is far below walk_cells_per_ray x (1 - end_cells / endpoints)).
  double super_ray_saving = 0.0;
  bool chooser_consulted = false;  ///< kFastest: this scan's method came from the chooser (else baseline)
  double prepare_ms = 0.0;         ///< validation, range cuts, bounding box (part of update_ms)
  double trace_ms = 0.0;           ///< ray traversals (part of update_ms)
  double apply_ms = 0.0;           ///< endpoints + applying the evidence to the map (part of update_ms)
  double generation_ms = 0.0;      ///< super rays + culling region
  double update_ms = 0.0;          ///< traversals + applying the evidence to the map
  double totalMs() const { return generation_ms + update_ms; }
};

class UpdateEngine {
 public:
  explicit UpdateEngine(UpdateOptions options = {});

  /// Runs the write that makes a scan visible (e.g. under a lock that readers share); the tracing before
  /// it, and the map's staging of new values (OccupancyMap::applyPublished), only read the map.
  using ApplyWrapper = map::OccupancyMap::Publisher;

  /// Inserts one scan: points and sensor origin in the map's (world) frame. Non-finite points are skipped
  /// and counted; a non-finite or out-of-range origin rejects the whole scan (returns nullopt). The map is
  /// changed once, at the end, inside `wrap` when given.
  std::optional<UpdateStats> insert(map::OccupancyMap& map, const std::vector<geometry::Vec3f>& points,
                                    const geometry::Vec3f& origin, const ApplyWrapper& wrap = {});

  const UpdateOptions& options() const { return options_; }
  void setOptions(const UpdateOptions& o) { options_ = o; }
  /// With kFastest: what was measured and chosen so far.
  const MethodChooser& chooser() const { return chooser_; }

 private:
  UpdateOptions options_;
  MethodChooser chooser_;
  bool consult_chooser_ = false;  // kFastest: the previous scan's super_ray_saving reached the threshold
  map::ScanEvidence evidence_;
  SuperRayGenerator generator_;
  // Per-scan buffers kept between scans (large, so reallocating them would page-fault every scan).
  std::vector<geometry::Vec3f> ends_, cut_ends_, clipped_;
  std::vector<std::size_t> part_starts_;  // parallel compaction: where each slice's copies begin
  std::vector<std::uint8_t> kind_;  // per point: 0 rejected, 1 ray with endpoint, 2 ray cut at max range
  std::vector<geometry::VoxelKey> keys_, end_keys_;  // per point / per endpoint: the endpoint's cell
  std::vector<geometry::VoxelKey> cell_keys_;        // count_cells: the cells with evidence
  std::vector<float> cell_before_;                   // and their log-odds before the scan
  std::vector<SuperRay> rays_;
};

}  // namespace densemap::update
