// densemap-durability-bench: what the journal costs and what a restart takes (the figures), in one
// process so the modes share the machine's state: per mode (journal off; on, uncompressed; on, zstd
// levels) the scans are mapped one at a time (each waits for its outcome, as a robot's acknowledgement
// does) and the per-scan time, journal bytes and fsyncs are recorded; then the service is stopped without
// a snapshot and restarted on its data directory (journal replay), snapshotted, and restarted again
// (snapshot load), and once more with a snapshot halfway (snapshot + replay). Modes alternate per round.
//   densemap-durability-bench --source ../shared/data/kitti00 --scans 0:59 --rounds 3 --json
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <map>
#include <mutex>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "bench_jobs.h"
#include "densemap/cli/cli_common.h"
#include "densemap/cli/common_options.h"
#include "densemap/cli/option_cli.h"
#include "densemap/server/map_service.h"
#include "densemap/sources/open_source.h"
#include "densemap/util/percentile.h"

using namespace densemap;
using Clock = std::chrono::steady_clock;
using tools::jobOf;
using tools::msSince;

namespace {

/// Maps `scans[first, last)` one at a time; returns each scan's submit-to-outcome time.
std::vector<double> mapOneByOne(server::MapService& service, const std::vector<io::Scan>& scans,
                                std::size_t first, std::size_t last) {
  std::mutex m;
  std::condition_variable cv;
  bool done = false;
  server::ScanOutcome outcome{};
  std::vector<double> ms;
  for (std::size_t i = first; i < last; ++i) {
    done = false;
    const auto t0 = Clock::now();
    service.submit(jobOf(scans[i], i),
                   [&](const server::ScanJob&, server::ScanOutcome o, const std::string&) {
                     std::lock_guard l(m);
                     outcome = o;
                     done = true;
                     cv.notify_all();
                   });
    std::unique_lock l(m);
    cv.wait(l, [&] { return done; });
    if (outcome != server::ScanOutcome::kInMap)
      throw std::runtime_error("scan " + std::to_string(i) + " was not applied");
    ms.push_back(msSince(t0));
  }
  return ms;
}

/// Constructs the service on its data directory (recovery included) and returns the time it took.
double restartMs(const server::ServiceOptions& options, std::uint64_t expect_records) {
  const auto t0 = Clock::now();
  server::MapService service(options);
  const double ms = msSince(t0);
  const auto& rec = service.recovery();
  if (!rec || rec->records_replayed != expect_records)
    throw std::runtime_error("restart replayed " + std::to_string(rec ? rec->records_replayed : 0) +
                             " records, expected " + std::to_string(expect_records));
  service.stop(true);
  return ms;
}

std::uint64_t snapshotNow(server::MapService& service) {
  const auto r = service.execute(server::SnapshotCommand{}, "bench");
  if (r.status != server::Status::kOk) throw std::runtime_error(r.message);
  return service.statistics().durability.snapshot_bytes;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return util::percentileOfSorted(v, 0.5);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"densemap-durability-bench: the journal's cost per scan and the restart time, mode by mode"};
  sources::SourceSelection source;
  std::string log_level = "warn";
  int rounds = 3;
  std::vector<int> zstd_levels{1, 3};
  int sync_ms = 10;
  bool as_json = false;
  server::ServiceOptions options;
  options.update_nice = 0;
  options.durability.snapshot_on_exit = false;  // the restarts below choose what the directory holds
  options.durability.snapshot_every_scans = 0;
  options.durability.snapshot_every_s = 0;
  auto map_table = map::mapOptionTable(options.map);
  auto logging_table = cli::loggingOptions(log_level);
  app.add_option("--rounds", rounds, "rounds (the modes alternate within each)")->capture_default_str();
  app.add_option("--zstd", zstd_levels, "zstd levels to measure beside uncompressed records")
      ->capture_default_str();
  app.add_option("--journal-sync-ms", sync_ms, "group commit window of the journaled modes")
      ->capture_default_str();
  app.add_flag("--json", as_json, "print one JSON object");
  auto source_table = sources::sourceOptionTable(source);
  cli::addToApp(app, {&source_table, &map_table, &logging_table});
  if (const auto rc = cli::parse(app, argc, argv, {&source_table, &map_table, &logging_table})) return *rc;
  cli::setupLogging(log_level);
  try {
    options.durability.journal_sync_ms = sync_ms;
    const auto src = sources::openSource(source.source, source.options);
    const auto range = cli::parseScanRange(source.scans, src->size());
    std::vector<io::Scan> scans;
    cli::Progress loading("loading", range.last - range.first + 1);
    for (std::size_t i = range.first; i <= range.last; ++i) {
      scans.push_back(src->read(i));
      loading.step(i - range.first + 1);
    }
    const std::size_t n = scans.size(), half = n / 2;
    const auto root =
        std::filesystem::temp_directory_path() / ("densemap-durability-bench-" + std::to_string(::getpid()));
    // Modes: journal off (the baseline), on uncompressed, on with each zstd level.
    std::vector<int> modes{-1, 0};
    modes.insert(modes.end(), zstd_levels.begin(), zstd_levels.end());
    auto modeName = [](int m) {
      return m < 0 ? std::string("off") : m == 0 ? std::string("on") : "zstd-" + std::to_string(m);
    };
    std::map<std::string, std::map<std::string, std::vector<double>>> fig;  // mode -> figure -> rounds
    std::size_t points = 0;
    for (const auto& s : scans) points += s.points.size();
    for (int r = 0; r < rounds; ++r) {
      for (const int mode : modes) {
        const std::string name = modeName(mode);
        server::ServiceOptions o = options;
        o.durability.journal = mode >= 0;
        o.durability.journal_zstd_level = std::max(mode, 0);
        std::filesystem::remove_all(root);
        o.map_dir = (root / "maps").string();
        o.data_dir = (root / "data").string();
        auto& f = fig[name];
        std::uint64_t bytes = 0, syncs = 0;
        {
          server::MapService service(o);
          const auto ms = mapOneByOne(service, scans, 0, n);
          f["scan_ms_median"].push_back(median(ms));
          double sum = 0;
          for (double x : ms) sum += x;
          f["map_all_s"].push_back(sum / 1000.0);
          const auto st = service.statistics();
          bytes = st.durability.bytes;
          syncs = st.durability.syncs;
          for (const auto& stage : st.stages)
            if (stage.name == "journal") f["journal_stage_ms_p50"].push_back(stage.latency.p50_ms);
          service.stop(true);
        }
        if (mode < 0) {
          std::fprintf(stderr, "round %d %-7s scan %6.1f ms (median)\n", r + 1, name.c_str(),
                       f["scan_ms_median"].back());
          continue;
        }
        f["bytes_per_scan"].push_back(static_cast<double>(bytes) / static_cast<double>(n));
        f["bytes_per_point"].push_back(static_cast<double>(bytes) / static_cast<double>(points));
        f["syncs"].push_back(static_cast<double>(syncs));
        // Restart on the journal alone (every scan replayed) ...
        f["restart_journal_ms"].push_back(restartMs(o, n));
        // ... on a snapshot of everything ...
        {
          server::MapService service(o);  // replays again, then snapshots
          f["snapshot_bytes"].push_back(static_cast<double>(snapshotNow(service)));
          service.stop(true);
        }
        f["restart_snapshot_ms"].push_back(restartMs(o, 0));
        // ... and on a snapshot after the first half plus the journal of the second.
        std::filesystem::remove_all(root);
        {
          server::MapService service(o);
          mapOneByOne(service, scans, 0, half);
          snapshotNow(service);
          mapOneByOne(service, scans, half, n);
          service.stop(true);
        }
        f["restart_half_ms"].push_back(restartMs(o, n - half));
        std::fprintf(stderr,
                     "round %d %-7s scan %6.1f ms (median); %.2f MB/scan; restart: journal %.0f ms, "
                     "snapshot %.0f ms, snapshot + %zu records %.0f ms\n",
                     r + 1, name.c_str(), f["scan_ms_median"].back(), f["bytes_per_scan"].back() / 1e6,
                     f["restart_journal_ms"].back(), f["restart_snapshot_ms"].back(), n - half,
                     f["restart_half_ms"].back());
      }
    }
    std::filesystem::remove_all(root);
    nlohmann::json out = {{"source", src->describe()},
                          {"scans", n},
                          {"points_per_scan", static_cast<double>(points) / static_cast<double>(n)},
                          {"rounds", rounds},
                          {"journal_sync_ms", sync_ms}};
    for (const auto& [mode, figures] : fig)
      for (const auto& [what, values] : figures) {
        out["modes"][mode][what + "_median"] = median(values);
        out["modes"][mode][what + "_rounds"] = values;
      }
    if (as_json) {
      std::printf("%s\n", out.dump(2).c_str());
    } else {
      for (const int mode : modes) {
        const auto& m = out["modes"][modeName(mode)];
        std::printf("%-7s scan %.1f ms", modeName(mode).c_str(), m["scan_ms_median_median"].get<double>());
        if (mode >= 0)
          std::printf(
              "; %.3f MB/scan; restart journal %.0f ms, snapshot %.0f ms, half %.0f ms",
              m["bytes_per_scan_median"].get<double>() / 1e6, m["restart_journal_ms_median"].get<double>(),
              m["restart_snapshot_ms_median"].get<double>(), m["restart_half_ms_median"].get<double>());
        std::printf("\n");
      }
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
