// The exact map update as a pipeline stage: the core's UpdateEngine (super rays + culling region by
// default) writing into the MapStore under its exclusive lock only for the final apply.
#pragma once

#include "densemap/server/map_store.h"
#include "densemap/server/pipeline_stage.h"
#include "densemap/update/update_engine.h"

namespace densemap::server {

class OccupancyStage : public PipelineStage {
 public:
  /// `nice` > 0 lowers the priority of the update threads (Linux nice value), so query and DDS threads
  /// that wake up take a core at once instead of waiting for a time slice.
  OccupancyStage(MapStore& store, update::UpdateOptions options, int nice = 0)
      : store_(store), engine_(options), nice_(nice) {}

  std::string name() const override { return "occupancy"; }
  StageResult process(ScanJob& job) override;
  bool commitsToMap() const override { return true; }
  void idle() override { store_.runCommands(); }

 private:
  MapStore& store_;
  update::UpdateEngine engine_;
  int nice_ = 0;
  bool niced_ = false;
};

}  // namespace densemap::server
