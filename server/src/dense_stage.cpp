#include "densemap/server/dense_stage.h"

#include "densemap/server/update_priority.h"

namespace densemap::server {

StageResult DenseStage::process(ScanJob& job) {
  if (!niced_ && nice_ > 0) setThreadsNice(openmpTeamThreadIds(), nice_);
  niced_ = true;
  return replay(job);
}

StageResult DenseStage::replay(ScanJob& job) {
  // The occupancy stage before this one left the points in the world frame.
  std::vector<geometry::Vec3f> converted;
  if (job.scan.frame != io::PointFrame::kWorld) converted = job.scan.worldPoints();
  const auto& points = job.scan.frame == io::PointFrame::kWorld ? job.scan.points : converted;
  auto prepared = store_.writerView().prepare(points, job.scan.origin());
  store_.write([&](dense::KernelLayer& layer) { layer.commit(prepared); });
  if (window_radius_m_ > 0.0) {
    robots_.update(job.robot_id, job.scan.origin(), static_cast<double>(job.received_ns) * 1e-9);
    // Found on the writer's own view without the lock; only the erasing holds up the readers.
    const auto far = store_.writerView().blocksFartherThan(robots_.positions(), window_radius_m_);
    if (!far.empty())
      store_.write([&](dense::KernelLayer& layer) { blocks_dropped_ += layer.dropBlocks(far); });
  }
  return {};
}

void DenseStage::applyChange(MapChange& change) {
  // A reset forgets both layers; a loaded map brings no dense evidence, so the layer starts over.
  if (std::holds_alternative<ResetCommand>(change.command) ||
      std::holds_alternative<LoadCommand>(change.command)) {
    if (change.result.status == Status::kOk) store_.write([](dense::KernelLayer& layer) { layer.clear(); });
  }
  // The writer reads its own layer without the lock: queries go on while the state is copied.
  if (std::holds_alternative<SnapshotCommand>(change.command) && change.result.status == Status::kOk)
    change.dense_state = store_.writerView().saveState();
}

}  // namespace densemap::server
