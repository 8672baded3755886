// The dense layer (AKIMap, or the BGK baseline) as a pipeline stage after the exact map. It may fall
// behind: its input queue drops the oldest waiting scans (counted in the stage statistics) so it always
// works on recent scans and never holds up the exact map. It is the dense layer's only writer: a reset or
// a load clears it here, in order with the scans. With the map window (--window-radius) its blocks
// farther than the radius from every robot are dropped after each scan: the dense layer is an estimate
// from the scans around the robots, which a robot coming back builds again; the exact map keeps every cell.
#pragma once

#include <atomic>
#include <cstdint>
#include "densemap/server/map_stores.h"

#include "densemap/server/pipeline_stage.h"
#include "densemap/server/robot_places.h"

namespace densemap::server {

class DenseStage : public PipelineStage {
 public:
  /// `nice` > 0: the stage's thread and its OpenMP team run at that nice value (set on the first scan).
  /// `overflow`: kDropOldest (default) keeps it on recent scans; kWait makes it take every scan (then it
  /// holds up the exact map when behind, and its layer is the offline layer of every acknowledged scan).
  /// `window_radius_m` > 0: blocks farther than that from every robot (robots silent for
  /// `robot_timeout_s` of map time are forgotten, 0: never) are dropped after each scan.
  explicit DenseStage(DenseStore& store, int nice = 0, OverflowPolicy overflow = OverflowPolicy::kDropOldest,
                      double window_radius_m = 0.0, double robot_timeout_s = 0.0)
      : store_(store),
        nice_(nice),
        overflow_(overflow),
        window_radius_m_(window_radius_m),
        robots_(robot_timeout_s) {}
  std::string name() const override { return "dense"; }
  OverflowPolicy inputPolicy() const override { return overflow_; }
  StageResult process(ScanJob& job) override;
  void applyChange(MapChange& change) override;
  /// process() without changing thread priorities: a journal replay at start-up, on the caller's thread.
  StageResult replay(ScanJob& job);
  /// Dense blocks dropped by the window this run (any thread).
  std::uint64_t blocksDropped() const { return blocks_dropped_.load(); }

 private:
  DenseStore& store_;
  int nice_ = 0;
  OverflowPolicy overflow_;
  bool niced_ = false;
  double window_radius_m_;
  RobotPlaces robots_;
  std::atomic<std::uint64_t> blocks_dropped_{0};
};

}  // namespace densemap::server
