// The dense layer (AKIMap, or the BGK baseline) as a pipeline stage after the exact map. It may fall
// behind: its input queue drops the oldest waiting scans (counted in the stage statistics) so it always
// works on recent scans and never holds up the exact map. It is the dense layer's only writer: a reset or
// a load clears it here, in order with the scans.
#pragma once

#include "densemap/server/map_stores.h"
#include "densemap/server/pipeline_stage.h"

namespace densemap::server {

class DenseStage : public PipelineStage {
 public:
  /// `nice` > 0: the stage's thread and its OpenMP team run at that nice value (set on the first scan).
  /// `overflow`: kDropOldest (default) keeps it on recent scans; kWait makes it take every scan (then it
  /// holds up the exact map when behind, and its layer is the offline layer of every acknowledged scan).
  explicit DenseStage(DenseStore& store, int nice = 0, OverflowPolicy overflow = OverflowPolicy::kDropOldest)
      : store_(store), nice_(nice), overflow_(overflow) {}
  std::string name() const override { return "dense"; }
  OverflowPolicy inputPolicy() const override { return overflow_; }
  StageResult process(ScanJob& job) override;
  void applyChange(MapChange& change) override;
  /// process() without changing thread priorities: a journal replay at start-up, on the caller's thread.
  StageResult replay(ScanJob& job);

 private:
  DenseStore& store_;
  int nice_ = 0;
  OverflowPolicy overflow_;
  bool niced_ = false;
};

}  // namespace densemap::server
