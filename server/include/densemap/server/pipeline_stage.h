// One step of the server's scan pipeline (densify -> occupancy update -> dense layer). Each stage runs on
// its own worker thread; later features add a stage without touching the others.
#pragma once

#include <string>

#include "densemap/server/bounded_queue.h"
#include "densemap/server/map_change.h"
#include "densemap/server/scan_job.h"

namespace densemap::server {

struct StageResult {
  bool ok = true;
  std::string error;  ///< why the scan was rejected (when !ok)
  static StageResult reject(std::string why) { return {false, std::move(why)}; }
};

class PipelineStage {
 public:
  virtual ~PipelineStage() = default;
  virtual std::string name() const = 0;
  /// Processes one scan; a rejection ends the scan's way through the pipeline.
  virtual StageResult process(ScanJob& job) = 0;
  /// True for the stage after which a scan counts as "in the map" (acknowledged, latency measured).
  virtual bool commitsToMap() const { return false; }
  /// Applies this stage's part of a command (on the stage's thread, between two scans). A stage that
  /// fails it sets change.result.status; later stages still see it.
  virtual void applyChange(MapChange& change) { (void)change; }
  /// How the stage's input queue behaves when the stage falls behind. A stage that may lag (a dense layer)
  /// drops the oldest scans; the exact map waits so that it never misses a scan.
  virtual OverflowPolicy inputPolicy() const { return OverflowPolicy::kWait; }
};

}  // namespace densemap::server
