#include "densemap/server/occupancy_stage.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include "densemap/msg/dds_node.h"

namespace densemap::server {

StageResult OccupancyStage::process(ScanJob& job) {
  if (!niced_ && nice_ > 0) {
    // This thread and the OpenMP workers it drives (the pool persists between parallel regions).
#pragma omp parallel
    setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), nice_);
    niced_ = true;
  }
  // Later stages (the dense layer) take the scan in the world frame: transform it once, here.
  if (job.scan.frame != io::PointFrame::kWorld) {
    job.scan.points = job.scan.worldPoints();
    job.scan.frame = io::PointFrame::kWorld;
  }
  const std::vector<geometry::Vec3f>& world = job.scan.points;
  std::uint64_t version = 0;
  const auto stats =
      engine_.insert(store_.writerView(), world, job.scan.origin(), [&](const std::function<void()>& apply) {
        store_.write([&](map::OccupancyMap&) { apply(); });
        version = store_.version();
      });
  if (!stats) {
    return StageResult::reject("the sensor origin lies outside the map's key range (|coordinate| > " +
                               std::to_string(store_.writerView().resolution() * geometry::kKeyCenter) +
                               " m)");
  }
  job.points_rejected += static_cast<std::uint32_t>(stats->rejected);
  job.map_version = version;
  job.in_map_ns = msg::nowNs();
  return {};
}

}  // namespace densemap::server
