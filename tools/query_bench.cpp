// densemap-query-bench: the measurement behind the batched point lookup of the server's point queries.
// Builds a map from a source, then answers the same random point batches (as densemap-replay's query
// clients draw them) with one logOdds() per point (the baseline) and with one logOddsMany() per batch,
// in the same process and alternating, with the caches flushed before every batch (a query arrives while
// the map update streams its blocks through the caches), and checks that both give the same values.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "densemap/cli/cli_common.h"
#include "densemap/cli/common_options.h"
#include "densemap/cli/option_cli.h"
#include "densemap/map/grid_map.h"
#include "densemap/map/map_factory.h"
#include "densemap/map/octree_map.h"
#include "densemap/sources/open_source.h"
#include "densemap/update/update_engine.h"
#include "densemap/util/percentile.h"

using namespace densemap;
using Clock = std::chrono::steady_clock;
using util::percentile;

namespace {
double us(Clock::time_point t) { return std::chrono::duration<double, std::micro>(Clock::now() - t).count(); }
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"densemap-query-bench: point-query lookups, one per point vs one batch, on a map of a source"};
  sources::SourceSelection source;
  map::MapOptions map_options;
  double radius = 20.0;
  std::size_t points = 1000, batches = 500;
  bool as_json = false;
  auto map_table = map::mapOptionTable(map_options);
  auto source_table = sources::sourceOptionTable(source);
  cli::addToApp(app, {&source_table, &map_table});
  app.add_option("--points", points, "points per query batch")->capture_default_str();
  app.add_option("--batches", batches, "query batches timed per method")->capture_default_str();
  app.add_option("--radius", radius,
                 "points are drawn within this many metres (x, y) of the last sensor origin")
      ->capture_default_str();
  app.add_flag("--json", as_json, "print one JSON object");
  if (const auto rc = cli::parse(app, argc, argv, {&source_table, &map_table})) return *rc;
  cli::setupLogging("warn");
  if (map_options.decay.enabled()) {
    spdlog::error("--decay-s: the query benchmark maps without decay; drop it");
    return 2;
  }
  try {
    const auto src = sources::openSource(source.source, source.options);
    const auto range = cli::parseScanRange(source.scans, src->size());
    std::unique_ptr<map::OccupancyMap> m = map::makeMap(map_options);
    update::UpdateEngine engine;
    geometry::Vec3f origin = geometry::Vec3f::Zero();
    for (std::size_t i = range.first; i <= range.last; ++i) {
      const io::Scan s = src->read(i);
      engine.insert(*m, s.worldPoints(), s.origin());
      origin = s.origin();
    }
    // Points as densemap-replay's query clients draw them: +-radius in x and y, -2..3 m in z.
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(-static_cast<float>(radius), static_cast<float>(radius)),
        uz(-2, 3);
    std::vector<char> flush(64 << 20, 0);
    auto flushCaches = [&] {
      for (std::size_t j = 0; j < flush.size(); j += 64) ++flush[j];
    };
    std::vector<double> single_us, batch_us;
    std::vector<geometry::VoxelKey> keys(points);
    std::vector<float> a(points), b(points);
    std::size_t known = 0, mismatches = 0;
    for (std::size_t rep = 0; rep < batches; ++rep) {
      for (auto& k : keys) {
        while (!m->converter().toKey(origin + geometry::Vec3f(u(rng), u(rng), uz(rng)), k)) {
        }
      }
      for (int pass = 0; pass < 2; ++pass) {
        const bool batch_first = rep % 2 == 1;  // alternate which method meets the flushed caches first
        flushCaches();
        const auto t0 = Clock::now();
        if ((pass == 0) == batch_first) {
          m->logOddsMany(keys, b);
          batch_us.push_back(us(t0));
        } else {
          for (std::size_t i = 0; i < points; ++i)
            a[i] = m->logOdds(keys[i]).value_or(std::numeric_limits<float>::quiet_NaN());
          single_us.push_back(us(t0));
        }
      }
      for (std::size_t i = 0; i < points; ++i) {
        known += !std::isnan(a[i]);
        mismatches += !(a[i] == b[i] || (std::isnan(a[i]) && std::isnan(b[i])));
      }
    }
    const double s50 = percentile(single_us, 0.5), b50 = percentile(batch_us, 0.5);
    nlohmann::json j = {{"source", src->describe()},
                        {"backend", map_options.backend},
                        {"resolution", map_options.resolution},
                        {"points", points},
                        {"batches", batches},
                        {"known_share", static_cast<double>(known) / static_cast<double>(points * batches)},
                        {"single_p50_us", s50},
                        {"single_p99_us", percentile(single_us, 0.99)},
                        {"batch_p50_us", b50},
                        {"batch_p99_us", percentile(batch_us, 0.99)},
                        {"speedup_p50", s50 / std::max(1e-9, b50)},
                        {"mismatches", mismatches}};
    if (as_json) {
      std::printf("%s\n", j.dump().c_str());
    } else {
      std::printf("%s, %s map at %.2f m; %zu batches of %zu points (%.0f%% known cells), caches flushed\n",
                  src->describe().c_str(), map_options.backend.c_str(), map_options.resolution, batches,
                  points, 100.0 * j["known_share"].get<double>());
      std::printf("one logOdds() per point: p50 %.1f us, p99 %.1f us\n", s50,
                  j["single_p99_us"].get<double>());
      std::printf("one logOddsMany() batch: p50 %.1f us, p99 %.1f us (%.2fx at p50), %zu mismatches\n", b50,
                  j["batch_p99_us"].get<double>(), j["speedup_p50"].get<double>(), mismatches);
    }
    return mismatches == 0 ? 0 : 1;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
