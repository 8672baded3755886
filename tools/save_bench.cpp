// densemap-save-bench: how long queries wait while the map is saved, the old way (encoding and writing
// under the map's shared lock: the next scan's exclusive lock waits behind it, and every new query waits
// behind that) against a save from a snapshot (MapService's SaveCommand: a copy on the writer thread, the
// write off it) and a durability snapshot (SnapshotCommand: both layers and the robots' progress into the
// data directory, then the journal behind it removed). Same process, same map, scans streaming at the
// given rate, modes alternating.
//   densemap-save-bench --source ../shared/data/kitti00 --scans 0:59 --rounds 3
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <random>
#include <thread>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "bench_jobs.h"
#include "densemap/cli/cli_common.h"
#include "densemap/cli/common_options.h"
#include "densemap/cli/option_cli.h"
#include "densemap/map/map_file.h"
#include "densemap/server/map_service.h"
#include "densemap/sources/open_source.h"
#include "densemap/util/percentile.h"

using namespace densemap;
using Clock = std::chrono::steady_clock;
using tools::jobOf;
using tools::msSince;

namespace {

struct Round {
  std::string mode;
  double save_ms = 0, query_p50_ms = 0, query_p99_ms = 0, query_max_ms = 0, snapshot_ms = 0;
  std::size_t queries = 0;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"densemap-save-bench: query latency during a map save, under the lock vs from a snapshot"};
  sources::SourceSelection source;  // --scans: mapped before the saves; the rest stream during them
  std::string log_level = "warn";
  int rounds = 3;
  double rate = 10.0;
  std::size_t points = 1000;
  bool as_json = false;
  server::ServiceOptions options;
  options.update_nice = 0;
  options.durability.snapshot_every_scans = 0;  // only the snapshots this bench asks for
  options.durability.snapshot_every_s = 0;
  options.durability.snapshot_on_exit = false;
  auto map_table = map::mapOptionTable(options.map);
  auto logging_table = cli::loggingOptions(log_level);
  app.add_option("--rounds", rounds, "saves per mode (modes alternate)")->capture_default_str();
  app.add_option("--rate", rate, "scans per second streaming during the saves")->capture_default_str();
  app.add_option("--points", points, "points per query (back to back from one thread)")
      ->capture_default_str();
  app.add_flag("--json", as_json, "print one JSON object");
  auto source_table = sources::sourceOptionTable(source);
  cli::addToApp(app, {&source_table, &map_table, &logging_table});
  if (const auto rc = cli::parse(app, argc, argv, {&source_table, &map_table, &logging_table})) return *rc;
  cli::setupLogging(log_level);
  try {
    const auto src = sources::openSource(source.source, source.options);
    const auto range = cli::parseScanRange(source.scans, src->size());
    const auto dir =
        std::filesystem::temp_directory_path() / ("densemap-save-bench-" + std::to_string(::getpid()));
    options.map_dir = dir.string();
    options.data_dir = (dir / "data").string();
    server::MapService service(options);
    std::vector<io::Scan> all;
    cli::Progress loading("loading", range.last - range.first + 1);
    for (std::size_t i = range.first; i <= range.last; ++i) {
      all.push_back(src->read(i));
      loading.step(i - range.first + 1);
    }
    // Map the first 80%; the rest stream during the saves (looping), so the writer wants its lock.
    const std::size_t base = std::max<std::size_t>(1, all.size() * 4 / 5);
    std::mutex m;
    std::condition_variable cv;
    std::size_t done = 0;
    auto onOutcome = [&](const server::ScanJob&, server::ScanOutcome, const std::string&) {
      std::lock_guard l(m);
      ++done;
      cv.notify_all();
    };
    for (std::size_t i = 0; i < base; ++i) service.submit(jobOf(all[i], i), onOutcome);
    {
      std::unique_lock l(m);
      cv.wait(l, [&] { return done >= base; });
    }
    const auto st = std::get<server::MapSummary>(service.answer(server::StatsQuery{}).result);
    std::fprintf(stderr, "map: %llu cells after %zu scans; %zu scans stream during the saves\n",
                 static_cast<unsigned long long>(st.known_cells), base, all.size() - base);
    std::atomic<bool> stop{false};
    std::uint64_t seq = base;
    std::thread streamer([&] {
      std::size_t k = base;
      while (!stop) {
        service.submit(jobOf(all[k], seq++), onOutcome);
        k = k + 1 < all.size() ? k + 1 : base;
        std::this_thread::sleep_for(std::chrono::duration<double>(1.0 / rate));
      }
    });
    // Query points around the last mapped origin.
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(-20.f, 20.f);
    const geometry::Vec3f c = all[base - 1].origin();
    server::PointsQuery q;
    for (std::size_t i = 0; i < points; ++i)
      q.points.push_back(c + geometry::Vec3f(u(rng), u(rng), u(rng) * 0.1f));
    std::vector<Round> results;
    const std::vector<std::string> modes{"under-lock", "snapshot", "journal-snapshot"};
    for (int r = 0; r < 3 * rounds; ++r) {
      Round round;
      round.mode = modes[static_cast<std::size_t>(r) % modes.size()];
      std::atomic<bool> saving{true};
      std::vector<double> waits;
      std::thread querier([&] {
        while (saving) {
          const auto t0 = Clock::now();
          service.answer(q);
          waits.push_back(msSince(t0));
        }
      });
      const auto t0 = Clock::now();
      const std::string name = "bench-" + std::to_string(r) + ".ot";
      if (round.mode == "under-lock") {
        // The old save: encode and write while holding the shared lock (what QueryService::save did).
        service.mapStore().read([&](const map::OccupancyMap& map, std::uint64_t) {
          map::saveMap(map, (dir / name).string());
          return 0;
        });
      } else if (round.mode == "journal-snapshot") {
        const auto res = service.execute(server::SnapshotCommand{}, "bench");
        if (res.status != server::Status::kOk) throw std::runtime_error(res.message);
        std::fprintf(stderr, "%s\n", res.message.c_str());  // its size and how long the copy held the update
      } else {
        const auto res = service.execute(server::SaveCommand{name}, "bench");
        if (res.status != server::Status::kOk) throw std::runtime_error(res.message);
      }
      round.save_ms = msSince(t0);
      saving = false;
      querier.join();
      std::sort(waits.begin(), waits.end());
      round.queries = waits.size();
      round.query_p50_ms = util::percentileOfSorted(waits, 0.5);
      round.query_p99_ms = util::percentileOfSorted(waits, 0.99);
      round.query_max_ms = waits.empty() ? 0 : waits.back();
      // How long the copy held up the map update: the newest sample's window maximum (one save a round).
      for (const auto& s : service.statistics().stages)
        if (s.name == "map-snapshot") round.snapshot_ms = s.latency.max_ms;
      std::fprintf(stderr, "%-10s save %7.1f ms; %5zu queries, wait p50 %6.2f p99 %7.2f max %7.2f ms\n",
                   round.mode.c_str(), round.save_ms, round.queries, round.query_p50_ms, round.query_p99_ms,
                   round.query_max_ms);
      results.push_back(round);
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
    stop = true;
    streamer.join();
    service.stop(true);
    std::filesystem::remove_all(dir);
    auto median = [&](const std::string& mode, double Round::*field) {
      std::vector<double> v;
      for (const auto& r : results)
        if (r.mode == mode) v.push_back(r.*field);
      std::sort(v.begin(), v.end());
      return util::percentileOfSorted(v, 0.5);
    };
    nlohmann::json out = {{"source", src->describe()},
                          {"known_cells", st.known_cells},
                          {"rounds", rounds},
                          {"points_per_query", points}};
    for (const std::string& mode : modes) {
      out[mode] = {{"save_ms_median", median(mode, &Round::save_ms)},
                   {"query_p99_ms_median", median(mode, &Round::query_p99_ms)},
                   {"query_max_ms_median", median(mode, &Round::query_max_ms)},
                   {"query_p50_ms_median", median(mode, &Round::query_p50_ms)}};
    }
    out["snapshot"]["snapshot_ms_max"] = median("snapshot", &Round::snapshot_ms);
    if (as_json) {
      std::printf("%s\n", out.dump(2).c_str());
    } else {
      std::printf(
          "medians of %d saves each: under the lock save %.0f ms, query max %.1f ms, p99 %.1f ms; "
          "from a snapshot save %.0f ms, query max %.1f ms, p99 %.1f ms; durability snapshot %.0f ms, query "
          "max %.1f ms, p99 %.1f ms\n",
          rounds, median("under-lock", &Round::save_ms), median("under-lock", &Round::query_max_ms),
          median("under-lock", &Round::query_p99_ms), median("snapshot", &Round::save_ms),
          median("snapshot", &Round::query_max_ms), median("snapshot", &Round::query_p99_ms),
          median("journal-snapshot", &Round::save_ms), median("journal-snapshot", &Round::query_max_ms),
          median("journal-snapshot", &Round::query_p99_ms));
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
