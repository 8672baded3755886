// The exact map update as a pipeline stage: the core's UpdateEngine (super rays + culling region by
// default) writing into the MapStore under its exclusive lock only for the final apply. It is the exact
// map's only writer: commands (clear box, reset, load, a save's snapshot) run here too, between scans.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>

#include "densemap/server/map_stores.h"
#include "densemap/server/map_window.h"
#include "densemap/server/pipeline_stage.h"
#include "densemap/server/update_priority.h"
#include "densemap/update/update_engine.h"

namespace densemap::server {

class OccupancyStage : public PipelineStage {
 public:
  /// `priority.low_nice` > 0 runs the update at that nice value while scans are on time, so query and
  /// DDS threads that wake up take a core at once instead of waiting for the update's time slice.
  /// `window` (may be null): the rolling window and memory cap, run around each scan.
  OccupancyStage(MapStore& store, update::UpdateOptions options, UpdatePriorityOptions priority = {0, {}},
                 MapWindow* window = nullptr)
      : store_(store), engine_(options), priority_(priority), window_(window) {}

  std::string name() const override { return "occupancy"; }
  StageResult process(ScanJob& job) override;
  bool commitsToMap() const override { return true; }
  void applyChange(MapChange& change) override;
  /// process() without the priority handling: a journal replay at start-up, on the caller's thread.
  StageResult replay(ScanJob& job);
  /// Scans run with each concrete method (update::kAllMethods' order); any thread may ask.
  std::array<std::uint64_t, 4> methodScans() const;

 private:
  StageResult apply(ScanJob& job);

  MapStore& store_;
  update::UpdateEngine engine_;
  UpdatePriority priority_;
  MapWindow* window_;
  std::array<std::atomic<std::uint64_t>, 4> method_scans_{};
};

}  // namespace densemap::server
