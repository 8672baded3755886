#include "densemap/server/occupancy_stage.h"

#include <algorithm>
#include <cmath>

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
  auto* grid = window_ ? dynamic_cast<map::GridMap*>(&store_.writerView()) : nullptr;
  if (grid != nullptr && grid->outOfMemoryCount() > 0) {  // the key box costs a pass over the points
    // The stored blocks this scan's rays can reach come back first, so it updates their real values.
    geometry::VoxelKey lo, hi;
    if (grid->converter().toKey(job.scan.origin(), lo)) {
      hi = lo;
      float reach2 = 0.0f;
      for (const auto& p : world) {
        geometry::VoxelKey k;
        if (!grid->converter().toKey(p, k)) continue;  // the engine skips these points too
        for (int a = 0; a < 3; ++a) {
          lo[a] = std::min(lo[a], k[a]);
          hi[a] = std::max(hi[a], k[a]);
        }
        reach2 = std::max(reach2, (p - job.scan.origin()).squaredNorm());
      }
      try {
        window_->bringBack(*grid, lo, hi, std::sqrt(reach2), publish_decay);
      } catch (const std::exception& e) {
        return StageResult::reject(
            fmt::format("a stored map block this scan reaches cannot be read ({}); the scan is refused so it "
                        "does not overwrite the stored cells",
                        e.what()));
      }
    }
  }
  std::uint64_t version = 0;
  const std::optional<update::UpdateStats> stats = engine_.insert(
      store_.writerView(), world, job.scan.origin(), [&](const std::function<void()>& publish) {
        store_.write([&](map::OccupancyMap&) { publish(); });
        version = store_.version();
      });
  if (!stats) {  // validateScan checks the origin first; kept so a missed case is a rejection, not a crash
    return StageResult::reject("the sensor origin lies outside the map's key range");
  }
  if (grid != nullptr)
    window_->afterScan(*grid, job.robot_id, job.scan.origin(), static_cast<double>(job.received_ns) * 1e-9,
                       publish_decay);
  method_scans_[static_cast<std::size_t>(stats->method)].fetch_add(1, std::memory_order_relaxed);
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
      // Named keys, not a structured binding: clang 14 cannot capture one in the lambdas below.
      const auto box = boxKeys(store_.writerView().converter(), clear->min, clear->max);
      const geometry::VoxelKey lo = box.first, hi = box.second;
      if (auto* grid = window_ ? dynamic_cast<map::GridMap*>(&store_.writerView()) : nullptr)
        window_->bringBack(*grid, lo, hi, 0.0f, [&](const std::function<void()>& commit) {
          store_.write([&](map::OccupancyMap&) { commit(); });
        });  // the box's stored cells are forgotten too (reach 0: not a scan)
      store_.write([&](map::OccupancyMap& m) { r.cells_changed = m.eraseBox(lo, hi); });
      r.message = fmt::format("cleared {} cells", r.cells_changed);
    } else if (const auto* load = std::get_if<LoadStoredBlocksCommand>(&change.command)) {
      auto* grid = window_ ? dynamic_cast<map::GridMap*>(&store_.writerView()) : nullptr;
      const std::size_t n =
          grid == nullptr
              ? 0
              : window_->bringBackForQuery(*grid, load->boxes, [&](const std::function<void()>& commit) {
                  store_.write([&](map::OccupancyMap&) { commit(); });
                });
      r.message = fmt::format("{} stored blocks back in memory for a query", n);
    } else if (std::holds_alternative<ResetCommand>(change.command)) {
      store_.write([&](map::OccupancyMap& m) {
        r.cells_changed = m.knownCells();
        m.clear();
      });
      if (window_) window_->forgetAll();
      r.message = fmt::format("reset: forgot {} cells", r.cells_changed);
    } else if (std::holds_alternative<LoadCommand>(change.command)) {
      r.cells_changed = change.loaded->knownCells();
      change.loaded->setMapTime(store_.writerView().mapTime());  // decay's clock goes on
      store_.replace(std::move(change.loaded));
      if (window_) window_->forgetAll();
    } else if (std::holds_alternative<SaveCommand>(change.command) ||
               std::holds_alternative<SnapshotCommand>(change.command)) {
      // The writer is the map's only writer, so it copies without the lock: readers go on meanwhile and
      // only the update waits for the copy (measured: snapshot_ms).
      const auto t0 = std::chrono::steady_clock::now();
      change.snapshot = store_.writerView().clone();
      if (window_ && std::holds_alternative<SnapshotCommand>(change.command)) {
        MapWindow::SnapshotPart part = window_->snapshotPart();
        change.window_state = std::move(part.state);
        change.window_files_to_sync = std::move(part.files_to_sync);
      }
      change.snapshot_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    }
    r.map_version = store_.version();
  });
}

std::array<std::uint64_t, 4> OccupancyStage::methodScans() const {
  std::array<std::uint64_t, 4> n{};
  for (std::size_t i = 0; i < n.size(); ++i) n[i] = method_scans_[i].load(std::memory_order_relaxed);
  return n;
}

}  // namespace densemap::server
