#include "densemap/server/occupancy_stage.h"

#include "densemap/msg/dds_node.h"

namespace densemap::server {

StageResult OccupancyStage::process(ScanJob& job) {
  // Later stages (the dense layer) take the scan in the world frame: transform it once, here.
  if (job.scan.frame != io::PointFrame::kWorld) {
    job.scan.points = job.scan.worldPoints();
    job.scan.frame = io::PointFrame::kWorld;
  }
  const std::vector<geometry::Vec3f>& world = job.scan.points;
  std::uint64_t version = 0;
  // Late once it has been in the server for the catch-up time (received_ns is system-clock time).
  const auto late_at = std::chrono::steady_clock::now() +
                       std::chrono::nanoseconds(job.received_ns - msg::nowNs()) + priority_.catchUp();
  std::optional<update::UpdateStats> stats;
  priority_.run(late_at, [&] {
    stats = engine_.insert(store_.writerView(), world, job.scan.origin(),
                           [&](const std::function<void()>& apply) {
                             store_.write([&](map::OccupancyMap&) { apply(); });
                             version = store_.version();
                           });
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
