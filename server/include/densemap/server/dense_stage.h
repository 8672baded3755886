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
  explicit DenseStage(DenseStore& store, int nice = 0) : store_(store), nice_(nice) {}
  std::string name() const override { return "dense"; }
  OverflowPolicy inputPolicy() const override { return OverflowPolicy::kDropOldest; }
  StageResult process(ScanJob& job) override;
  void applyChange(MapChange& change) override;

 private:
  DenseStore& store_;
  int nice_ = 0;
  bool niced_ = false;
};

}  // namespace densemap::server
