#include "densemap/server/occupancy_stage.h"

#include <fmt/format.h>

#include "densemap/server/box_keys.h"
#include "densemap/server/request_error.h"
#include "densemap/util/wall_clock.h"

namespace densemap::server {

StageResult OccupancyStage::process(ScanJob& job) {
  // Late once it has been in the server for the catch-up time (received_ns is system-clock time).
  const auto late_at = std::chrono::steady_clock::now() +
                       std::chrono::nanoseconds(job.received_ns - util::wallClockNs()) + priority_.catchUp();
  StageResult result;
  priority_.run(late_at, [&] { result = apply(job); });
  return result;
}

StageResult OccupancyStage::replay(ScanJob& job) { return apply(job); }

StageResult OccupancyStage::apply(ScanJob& job) {
  // Later stages (the dense layer) take the scan in the world frame: transform it once, here.
  if (job.scan.frame != io::PointFrame::kWorld) {
    job.scan.points = job.scan.worldPoints();
    job.scan.frame = io::PointFrame::kWorld;
  }
  const std::vector<geometry::Vec3f>& world = job.scan.points;
  // Map time is the scans' receive time (journaled, so a replay decays the same); decay steps run before
  // the scan so its culling region sees the decayed map.
  auto publish_decay = [&](const std::function<void()>& commit) {
    store_.write([&](map::OccupancyMap&) { commit(); });
  };
  store_.writerView().advanceTime(static_cast<double>(job.received_ns) * 1e-9, publish_decay);
  std::uint64_t version = 0;
  const std::optional<update::UpdateStats> stats = engine_.insert(
      store_.writerView(), world, job.scan.origin(), [&](const std::function<void()>& publish) {
        store_.write([&](map::OccupancyMap&) { publish(); });
        version = store_.version();
      });
  if (!stats) {  // validateScan checks the origin first; kept so a missed case is a rejection, not a crash
    return StageResult::reject("the sensor origin lies outside the map's key range");
  }
  job.points_rejected += static_cast<std::uint32_t>(stats->rejected);
  job.map_version = version;
  job.in_map_ns = util::wallClockNs();
  return {};
}

void OccupancyStage::applyChange(MapChange& change) {
  CommandResult& r = change.result;
  if (r.status != Status::kOk) return;  // refused before (the journal could not take it): not applied
  reportingErrors(r, [&] {
    if (const auto* clear = std::get_if<ClearBoxCommand>(&change.command)) {
      const auto [lo, hi] = boxKeys(store_.writerView().converter(), clear->min, clear->max);
      store_.write([&](map::OccupancyMap& m) { r.cells_changed = m.eraseBox(lo, hi); });
      r.message = fmt::format("cleared {} cells", r.cells_changed);
    } else if (std::holds_alternative<ResetCommand>(change.command)) {
      store_.write([&](map::OccupancyMap& m) {
        r.cells_changed = m.knownCells();
        m.clear();
      });
      r.message = fmt::format("reset: forgot {} cells", r.cells_changed);
    } else if (std::holds_alternative<LoadCommand>(change.command)) {
      r.cells_changed = change.loaded->knownCells();
      change.loaded->setMapTime(store_.writerView().mapTime());  // decay's clock goes on
      store_.replace(std::move(change.loaded));
    } else if (std::holds_alternative<SaveCommand>(change.command) ||
               std::holds_alternative<SnapshotCommand>(change.command)) {
      // The writer is the map's only writer, so it copies without the lock: readers go on meanwhile and
      // only the update waits for the copy (measured: snapshot_ms).
      const auto t0 = std::chrono::steady_clock::now();
      change.snapshot = store_.writerView().clone();
      change.snapshot_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    }
    r.map_version = store_.version();
  });
}

}  // namespace densemap::server
