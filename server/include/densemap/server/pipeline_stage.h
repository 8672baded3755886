// One step of the server's scan pipeline (densify -> occupancy update -> dense layer). Each stage runs on
// its own worker thread; later features add a stage without touching the others.
#pragma once

#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "densemap/server/bounded_queue.h"
#include "densemap/server/map_change.h"
#include "densemap/server/scan_job.h"

namespace densemap::server {

struct StageResult {
  bool ok = true;
  std::string error;       ///< why the scan was rejected (when !ok), or why it is a duplicate
  bool duplicate = false;  ///< with !ok: the scan is in the map already (outcome kDuplicate)
  /// The stage had nothing to do for this scan (densify and a scan already dense): its time is left out
  /// of the stage's latency, which then says what the stage costs the scans it works on.
  bool passed_through = false;
  static StageResult reject(std::string why) { return {false, std::move(why), false, false}; }
  static StageResult alreadyInMap(std::string why) { return {false, std::move(why), true, false}; }
  static StageResult passThrough() { return {true, {}, false, true}; }
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

  /// A stage that works on groups (the journal: one fsync per group) returns how long a group stays open
  /// after its first job; the pipeline then calls processGroup() instead of process() and applyChange().
  virtual std::optional<std::chrono::microseconds> groupWindow() const { return std::nullopt; }
  /// Every job of a group in order (scans and commands); results[i] is job i's (scans only).
  virtual void processGroup(std::vector<ScanJob>& jobs, std::vector<StageResult>& results) {
    (void)jobs;
    (void)results;
  }
};

}  // namespace densemap::server
