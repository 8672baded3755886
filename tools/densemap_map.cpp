// densemap-map: builds an occupancy map offline from any scan source and prints a summary.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "densemap/cli/cli_common.h"
#include "densemap/cli/common_options.h"
#include "densemap/cli/option_cli.h"
#include "densemap/map/grid_map.h"
#include "densemap/map/map_factory.h"
#include "densemap/map/map_file.h"
#include "densemap/map/octree_map.h"
#include "densemap/sources/open_source.h"
#include "densemap/update/update_engine.h"
#include "densemap/util/retain_freed_memory.h"

using namespace densemap;

int main(int argc, char** argv) {
  CLI::App app{
      "densemap-map: build an occupancy map from scans (exact log-odds map, super rays + culling region)"};
  sources::SourceSelection source;
  std::string output, log_level = "info";
  map::MapOptions map_options;
  map_options.backend = "octree";  // this tool writes OctoMap files by default
  update::UpdateOptions opt;
  int threads = 0;
  unsigned threshold = 20;
  std::size_t closure_every = 8;
  auto map_table = map::mapOptionTable(map_options);
  auto update_table = update::updateOptionTable(opt);
  auto logging_table = cli::loggingOptions(log_level);
  app.set_config("--config", "", "TOML/INI file with any of these options (flags override it)");
  auto source_table = sources::sourceOptionTable(source);
  cli::addToApp(app, {&source_table, &map_table, &update_table, &logging_table});
  app.add_option("--super-ray-threshold", threshold, "min points per voxel for super rays (k)")
      ->capture_default_str();
  app.add_option("--closure-sample", closure_every,
                 "culling + batch: walk every N-th ray first, then close the region over its marks (0: off)")
      ->capture_default_str();
  app.add_option("--output", output, "save the map: .bt or .ot (octree backend)");
  app.add_option("--threads", threads, "worker threads (0 = all cores)")->capture_default_str();
  int loops = 1;
  app.add_option("--loops", loops,
                 "map the range this many times in order (as densemap-replay --loops sends it)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  std::string order_file;
  app.add_option(
      "--order", order_file,
      "map the scans in this order: a file of sequence numbers as densemap-replay numbers them (scan "
      "= first of the range + number mod its length), e.g. a server's applied order "
      "(densemap-query progress)");
  double scan_period_s = 0.1;
  app.add_option("--scan-period-s", scan_period_s,
                 "map time between scans, decay's clock (--decay-s): scan n of the run is at n times this")
      ->capture_default_str()
      ->check(CLI::Range(1e-6, 1e6));
  bool as_sent = false;
  app.add_flag(
      "--as-sent", as_sent,
      "take each pose through position + unit quaternion, as densemap-replay sends it and the server "
      "rebuilds it: the map then equals the server's bit for bit");
  if (const auto rc = cli::parse(app, argc, argv, {&source_table, &map_table, &update_table, &logging_table}))
    return *rc;
  densemap::util::retainFreedMemory();
  cli::setupLogging(log_level);
  const int used_threads = cli::setThreads(threads);

  try {
    auto src = sources::openSource(source.source, source.options);
    const auto range = cli::parseScanRange(source.scans, src->size());
    spdlog::info("source: {}", src->describe());
    opt.super_rays.threshold = threshold;
    opt.in_scan_closure = closure_every > 0;
    opt.closure_sample_every = closure_every;
    std::unique_ptr<map::OccupancyMap> m = map::makeMap(map_options);
    update::UpdateEngine engine(opt);
    update::UpdateStats total;
    std::size_t done = 0, rejected_scans = 0;
    const std::size_t per_loop = range.last - range.first + 1;
    std::vector<std::uint64_t> order;  // sequence numbers in the order to map them
    if (!order_file.empty()) {
      std::ifstream in(order_file);
      if (!in) throw std::runtime_error("cannot read --order " + order_file);
      std::uint64_t seq = 0;
      while (in >> seq) order.push_back(seq);
      if (!in.eof()) throw std::runtime_error("--order " + order_file + ": not a list of sequence numbers");
    } else {
      for (std::uint64_t n = 0; n < per_loop * static_cast<std::uint64_t>(loops); ++n) order.push_back(n);
    }
    cli::Progress progress("mapping", order.size());
    std::vector<std::optional<io::Scan>> cached(per_loop);  // each scan read once
    for (std::size_t n = 0; n < order.size(); ++n) {
      const std::size_t k = static_cast<std::size_t>(order[n] % per_loop), i = range.first + k;
      if (!cached[k]) {
        io::Scan read = src->read(i);
        if (as_sent)
          read.pose = io::poseFromQuaternion(
              {read.pose.translation().x(), read.pose.translation().y(), read.pose.translation().z()},
              io::quaternionOf(read.pose));
        cached[k] = std::move(read);
      }
      const io::Scan& s = *cached[k];
      m->advanceTime(static_cast<double>(n) * scan_period_s,
                     [](const std::function<void()>& commit) { commit(); });
      auto st = engine.insert(*m, s.worldPoints(), s.origin());
      progress.step(n + 1);
      if (!st) {
        ++rejected_scans;
        spdlog::warn("scan {}: sensor origin is not finite or outside the map's key range; scan skipped", i);
        continue;
      }
      ++done;
      total.points += st->points;
      total.rejected += st->rejected;
      total.traversed += st->traversed;
      total.rays += st->rays;
      total.generation_ms += st->generation_ms;
      total.update_ms += st->update_ms;
      total.prepare_ms += st->prepare_ms;
      total.trace_ms += st->trace_ms;
      total.apply_ms += st->apply_ms;
      spdlog::debug(
          "scan {}: {} points, {:.1f} ms (prepare {:.1f}, generation {:.1f}, trace {:.1f}, apply {:.1f})", i,
          st->points, st->totalMs(), st->prepare_ms, st->generation_ms, st->trace_ms, st->apply_ms);
    }
    std::size_t occupied = 0, free_cells = 0;
    const float occ = m->logOddsParams().occupied;
    m->forEachCell([&](const geometry::VoxelKey&, float v) { (v > occ ? occupied : free_cells)++; });
    std::printf("densemap-map summary\n");
    std::printf("  source          %s\n", src->describe().c_str());
    std::printf("  scans           %zu mapped, %zu rejected (range %zu:%zu)\n", done, rejected_scans,
                range.first, range.last);
    std::printf("  points          %llu (%llu rejected: non-finite or out of key range)\n",
                static_cast<unsigned long long>(total.points),
                static_cast<unsigned long long>(total.rejected));
    std::printf("  map             %s, %.3f m, %s semantics, method %s, %d threads\n",
                map_options.backend.c_str(), map_options.resolution,
                std::string(map::toString(opt.semantics)).c_str(),
                std::string(update::toString(opt.method)).c_str(), used_threads);
    std::printf("  time            %.1f ms/scan (generation %.1f + update %.1f), %.1f scans/s\n",
                done ? total.totalMs() / static_cast<double>(done) : 0.0,
                done ? total.generation_ms / static_cast<double>(done) : 0.0,
                done ? total.update_ms / static_cast<double>(done) : 0.0,
                total.totalMs() > 0 ? 1000.0 * static_cast<double>(done) / total.totalMs() : 0.0);
    std::printf("  phases          prepare %.1f, trace %.1f, apply %.1f ms/scan\n",
                total.prepare_ms / std::max<double>(1, done), total.trace_ms / std::max<double>(1, done),
                total.apply_ms / std::max<double>(1, done));
    std::printf("  rays            %llu traversals, %llu cells traversed\n",
                static_cast<unsigned long long>(total.rays),
                static_cast<unsigned long long>(total.traversed));
    std::printf("  cells           %zu known: %zu occupied, %zu free; %.1f MB\n", occupied + free_cells,
                occupied, free_cells, static_cast<double>(m->memoryBytes()) / 1e6);
    if (!output.empty()) {
      map::saveMap(*m, output);  // any backend; throws with a message on failure
      std::printf("  saved           %s (open with octovis)\n", output.c_str());
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
