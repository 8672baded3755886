// densemap-decay-bench: the decay figures, in one process.
//  1. The time to clear a moved obstacle: the moving-box room (io/moving_box_room.h: the box moves to a
//     place that hides its old one from every ray) at 10 Hz, for each decay time and without decay: how
//     long after the move until no cell of the old place reads occupied, and until all are unknown; and
//     whether every wall cell the scans still hit stayed occupied.
//  2. What decay costs the update: the same scans mapped without and with decay, alternating, per round;
//     medians of the time per scan (decay steps included) and the map's memory at the end.
//   densemap-decay-bench --source ../shared/data/kitti00 --scans 0:99 --rounds 3 --decay-s 10
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "densemap/cli/cli_common.h"
#include "densemap/cli/common_options.h"
#include "densemap/cli/option_cli.h"
#include "densemap/io/moving_box_room.h"
#include "densemap/map/grid_map.h"
#include "densemap/sources/open_source.h"
#include "densemap/util/percentile.h"
#include "densemap/util/wall_clock.h"

using namespace densemap;

namespace {

const auto kNoLock = [](const std::function<void()>& commit) { commit(); };

struct Clearing {
  double decay_s = 0;
  std::optional<double> not_occupied_s, unknown_s;  // after the move
  std::size_t old_cells = 0, walls = 0, walls_lost = 0;
};

Clearing clearMovedBox(double decay_s, double step_s, double period_s, double horizon_s) {
  const int move_at = 20;
  io::MovingBoxRoom room({move_at + static_cast<int>(horizon_s / period_s), move_at});
  map::GridMap m(0.2);
  m.setDecay({decay_s, step_s});
  update::UpdateEngine engine;
  Clearing c;
  c.decay_s = decay_s;
  std::vector<geometry::VoxelKey> old_cells, walls;
  const float occ = m.logOddsParams().occupied;
  for (std::size_t i = 0; i < room.size(); ++i) {
    const double t = static_cast<double>(i) * period_s;
    m.advanceTime(t, kNoLock);
    const io::Scan s = room.read(i);
    engine.insert(m, s.worldPoints(), s.origin());
    if (static_cast<int>(i) == move_at - 1) {
      const auto& b = room.oldPlace();
      m.forEachCell([&](const geometry::VoxelKey& k, float v) {
        const Eigen::Vector3d p = m.converter().toCoord(k).cast<double>();
        if (v > occ && (p.array() > b.lo.array() - 0.05).all() && (p.array() < b.hi.array() + 0.05).all())
          old_cells.push_back(k);
      });
      for (const auto& p : room.read(room.size() - 1).worldPoints()) {  // walls the moved box leaves in view
        geometry::VoxelKey k;
        if ((std::abs(p.x()) > 9.9f || std::abs(p.y()) > 9.9f) && m.converter().toKey(p, k))
          walls.push_back(k);
      }
    }
    if (static_cast<int>(i) < move_at) continue;
    const double since = t - static_cast<double>(move_at) * period_s;
    bool any_occupied = false, all_unknown = true;
    for (const auto& k : old_cells) {
      const auto v = m.logOdds(k);
      any_occupied |= v && *v > occ;
      all_unknown &= !v.has_value();
    }
    if (!any_occupied && !c.not_occupied_s) c.not_occupied_s = since;
    if (all_unknown && !c.unknown_s) c.unknown_s = since;
    for (const auto& k : walls) {
      const auto v = m.logOdds(k);
      if (!(v && *v > occ)) ++c.walls_lost;
    }
  }
  c.old_cells = old_cells.size();
  c.walls = walls.size();
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"densemap-decay-bench: the time decay takes to clear a moved obstacle, and its update cost"};
  sources::SourceSelection source;
  std::string log_level = "warn";
  map::MapOptions map_options;  // --decay-s / --decay-step-s: the setting whose cost part 2 measures
  map_options.decay.seconds_to_unknown = 10.0;
  update::UpdateOptions update_options;
  int rounds = 3;
  double period_s = 0.1;
  std::vector<double> clear_times{2.0, 5.0, 10.0};
  auto map_table = map::mapOptionTable(map_options);
  auto update_table = update::updateOptionTable(update_options);
  auto logging_table = cli::loggingOptions(log_level);
  auto source_table = sources::sourceOptionTable(source);
  app.add_option("--rounds", rounds, "rounds of part 2 (without and with decay alternate)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--scan-period-s", period_s, "map time between scans (10 Hz: 0.1)")
      ->capture_default_str()
      ->check(CLI::Range(0.001, 10.0));
  app.add_option("--clear-decay-s", clear_times, "part 1: the decay times to try (0 is always tried)")
      ->capture_default_str();
  cli::addToApp(app, {&source_table, &map_table, &update_table, &logging_table});
  if (const auto rc = cli::parse(app, argc, argv, {&source_table, &map_table, &update_table, &logging_table}))
    return *rc;
  cli::setupLogging(log_level);
  if (map_options.backend != "grid" || !map_options.decay.enabled()) {
    spdlog::error("decay needs --backend grid and --decay-s > 0");
    return 2;
  }
  try {
    // Part 1.
    double horizon = 4.0;
    for (double d : clear_times) horizon = std::max(horizon, d + 4.0 * map_options.decay.step_s + 2.0);
    std::printf("1. moving-box room, 0.2 m, 10 Hz, decay step %.2f s: time after the move\n",
                map_options.decay.step_s);
    std::printf(
        "   decay_s  old cells  no longer occupied  all unknown  wall cells still hit / lost (cell-scans)\n");
    std::vector<double> all = {0.0};
    all.insert(all.end(), clear_times.begin(), clear_times.end());
    for (double d : all) {
      const Clearing c = clearMovedBox(d, map_options.decay.step_s, period_s, horizon);
      auto fmt_s = [&](const std::optional<double>& v) {
        return v ? fmt::format("{:.1f} s", *v) : fmt::format("> {:.0f} s", horizon);
      };
      std::printf("   %7s  %9zu  %18s  %11s  %zu / %zu\n", d > 0 ? fmt::format("{:.1f}", d).c_str() : "off",
                  c.old_cells, fmt_s(c.not_occupied_s).c_str(), fmt_s(c.unknown_s).c_str(), c.walls,
                  c.walls_lost);
    }

    // Part 2.
    const auto src = sources::openSource(source.source, source.options);
    const auto range = cli::parseScanRange(source.scans, src->size());
    const std::vector<cli::WorldScan> scans = cli::loadScans(*src, range);
    std::printf(
        "2. %s, scans %zu:%zu, %.2f m grid, %s, %.1f s between scans: ms per scan (median of rounds)\n",
        src->describe().c_str(), range.first, range.last, map_options.resolution,
        std::string(update::toString(update_options.method)).c_str(), period_s);
    std::vector<double> off_ms, on_ms, step_ms;
    double off_mb = 0, on_mb = 0;
    std::size_t off_cells = 0, on_cells = 0;
    for (int r = 0; r < rounds; ++r) {
      for (bool decay : {false, true}) {
        map::MapOptions o = map_options;
        if (!decay) o.decay = {};
        auto m = map::makeMap(o);
        update::UpdateEngine engine(update_options);
        const auto t0 = util::wallClockNs();
        double steps = 0;
        for (std::size_t i = 0; i < scans.size(); ++i) {
          const auto ts = util::wallClockNs();
          if (m->advanceTime(static_cast<double>(i) * period_s, kNoLock))
            steps += static_cast<double>(util::wallClockNs() - ts) / 1e6;
          engine.insert(*m, scans[i].points, scans[i].origin);
        }
        const double ms =
            static_cast<double>(util::wallClockNs() - t0) / 1e6 / static_cast<double>(scans.size());
        (decay ? on_ms : off_ms).push_back(ms);
        if (decay) step_ms.push_back(steps);
        (decay ? on_mb : off_mb) = static_cast<double>(m->memoryBytes()) / 1e6;
        (decay ? on_cells : off_cells) = m->knownCells();
        std::printf("   round %d %-13s %7.1f ms/scan\n", r + 1, decay ? "with decay" : "without decay", ms);
      }
    }
    const double off = util::percentile(off_ms, 50), on = util::percentile(on_ms, 50);
    std::printf("   without decay %.1f ms/scan, %zu cells, %.2f MB\n", off, off_cells, off_mb);
    std::printf(
        "   with decay    %.1f ms/scan (x%.3f), %zu cells, %.2f MB; all decay steps of a round %.1f ms\n", on,
        on / off, on_cells, on_mb, util::percentile(step_ms, 50));
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
