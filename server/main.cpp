// densemap-server: the DDS mapping service. Runs with no configuration; a TOML file (--config, same names
// as the long flags) and flags override the defaults.
#include <csignal>
#include <cstdio>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "densemap/cli/cli_common.h"
#include "densemap/msg/dds_options_cli.h"
#include "densemap/server/dds_edge/dds_edge.h"
#include "densemap/server/map_service.h"
#include "densemap/util/retain_freed_memory.h"

using namespace densemap;

int main(int argc, char** argv) {
  CLI::App app{"densemap-server: builds an occupancy map from LiDAR scans on DDS and answers queries"};
  server::ServiceOptions o;
  server::dds_edge::DdsEdgeOptions e;
  std::string method = "superrays+culling", semantics = "batch", overflow = "wait", log_level = "info";
  app.set_config("--config", "", "TOML file with any of these options (flags override it)");
  msg::addDdsOptions(app, e.dds);
  app.add_option("--server-id", o.server_id, "name in statistics and logs")->capture_default_str();
  app.add_option("--backend", o.map.backend, "map backend: grid or octree")
      ->capture_default_str()
      ->check(CLI::IsMember({"grid", "octree"}));
  app.add_option("--resolution", o.map.resolution, "voxel size in metres")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--method", method, "update method: baseline, superrays, culling or superrays+culling")
      ->capture_default_str()
      ->check(CLI::IsMember({"baseline", "superrays", "culling", "superrays+culling"}));
  app.add_option("--semantics", semantics, "batch (OctoMap insertPointCloud) or counting (Sec. 2.3.4)")
      ->capture_default_str()
      ->check(CLI::IsMember({"batch", "counting"}));
  app.add_option("--max-range", o.update.max_range, "cut rays at this range in metres (<0: unlimited)")
      ->capture_default_str();
  app.add_option("--prob-hit", o.map.params.prob_hit, "P(occupied) of a cell holding an endpoint")
      ->capture_default_str();
  app.add_option("--prob-miss", o.map.params.prob_miss, "P(occupied) of a cell a ray crosses")
      ->capture_default_str();
  app.add_option("--clamp-min", o.map.params.clamp_min, "lower clamping probability")->capture_default_str();
  app.add_option("--clamp-max", o.map.params.clamp_max, "upper clamping probability")->capture_default_str();
  app.add_option("--dense-layer", o.dense.method,
                 "dense layer stage after the exact map: none, akimap or bgk")
      ->capture_default_str()
      ->check(CLI::IsMember({"none", "akimap", "bgk"}));
  app.add_option("--dense-resolution", o.dense.resolution, "dense layer cell size (0: the map's)")
      ->capture_default_str();
  app.add_option("--dense-free-voxel", o.dense.free_voxel_size,
                 "dense layer: one free sample per voxel of this size (0: its resolution)")
      ->capture_default_str();
  app.add_flag("--dense-isotropic-free", o.dense.isotropic_free_kernels,
               "AKIMap: isotropic kernels for free samples (docs/BENCHMARKS.md)");
  app.add_option(
         "--dense-min-occupied-radius", o.dense.min_occupied_search_radius,
         "AKIMap: floor of occupied samples' neighbour search radius in metres (0: the dissertation's)")
      ->capture_default_str();
  app.add_option("--dense-max-range", o.dense.max_range, "dense layer: cut rays here (metres; <0: unlimited)")
      ->capture_default_str();
  app.add_option("--dense-nice", o.dense_nice,
                 "nice value of the dense layer's threads (0-19); it drops scans rather than fall behind")
      ->capture_default_str()
      ->check(CLI::Range(0, 19));
  std::vector<std::string> densify_robots;
  app.add_option("--densify", o.densify.method,
                 "densify stage before the map (Ch. 4): none, iln (trained network) or bilinear")
      ->capture_default_str()
      ->check(CLI::IsMember({"none", "iln", "bilinear"}));
  app.add_option("--densify-weights", o.densify.weights, "ILN weights (default: models/iln/iln_compact.pt)");
  app.add_option("--densify-input-rows", o.densify.input_rows,
                 "densify scans from LiDARs with this many beams (0: every scan carrying its geometry)")
      ->capture_default_str();
  app.add_option("--densify-robots", densify_robots, "densify exactly these robots' scans instead")
      ->delimiter(',');
  app.add_option("--densify-rows", o.densify.target_rows, "beams after densifying")->capture_default_str();
  app.add_option("--densify-columns", o.densify.target_columns, "columns after densifying (0: the input's)")
      ->capture_default_str();
  app.add_option("--densify-threads", o.densify.threads, "threads of the densify network")
      ->capture_default_str();
  app.add_option("--robot-queue", o.pipeline.robot_queue_capacity, "scans each robot may have waiting")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option(
         "--overflow", overflow,
         "when a robot's queue is full: wait (slow the robot down, lose nothing) or drop_oldest (counted)")
      ->capture_default_str()
      ->check(CLI::IsMember({"wait", "drop_oldest"}));
  app.add_option("--max-robots", o.pipeline.max_robots, "robots served at most")->capture_default_str();
  app.add_option("--max-points", o.limits.max_points, "scans with more points are rejected")
      ->capture_default_str();
  app.add_option("--query-threads", e.query_threads, "threads answering queries")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  app.add_option("--update-threads", o.update_threads, "threads of the map update (0 = all cores)")
      ->capture_default_str();
  app.add_option("--update-nice", o.update_nice,
                 "nice value of the map update while scans are on time (0-19; -1: 19 if the server may "
                 "raise it back when a scan is late, else 0); above 0 queries get a core sooner")
      ->capture_default_str()
      ->check(CLI::Range(-1, 19));
  app.add_option("--update-catch-up-ms", o.update_catch_up_ms,
                 "a scan is late this long after it arrived: its update then runs at normal priority")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--update-late-nice", o.update_late_nice,
                 "nice value of a late scan's update (-20..0): below 0 the map falls less far behind under a "
                 "flood of queries, at their cost; needs root, CAP_SYS_NICE or RLIMIT_NICE")
      ->capture_default_str()
      ->check(CLI::Range(-20, 0));
  app.add_option("--latency-slice-us", e.latency_slice_us,
                 "scheduler slice of the DDS and query threads in microseconds (Linux >= 6.12; 0: the "
                 "kernel's default)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--realtime-priority", e.realtime_priority,
                 "SCHED_FIFO priority (1-99) of the DDS and query threads, so the map update never delays "
                 "a query's answer (needs root, CAP_SYS_NICE or `ulimit -r`); 0: normal scheduling")
      ->capture_default_str()
      ->check(CLI::Range(0, 99));
  app.add_option("--statistics-period", e.statistics_period_s, "seconds between statistics messages (0: off)")
      ->capture_default_str();
  app.add_option("--data-dir", o.data_dir, "the service's data directory (saved maps go to DATA_DIR/maps)")
      ->capture_default_str();
  app.add_option("--map-dir", o.map_dir, "where save and load requests read and write (default DATA_DIR/maps)");
  app.add_option("--save-on-exit", o.save_on_exit, "save the map here (.bt/.ot) when shutting down");
  app.add_flag("!--drop-on-exit", o.drain_on_exit,
               "on shutdown drop queued scans (counted) instead of mapping them");
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  densemap::util::retainFreedMemory();
  cli::setupLogging(log_level);
  o.update.method = *update::parseMethod(method);
  o.update.semantics = *map::parseSemantics(semantics);
  o.pipeline.overflow = *server::parseOverflowPolicy(overflow);
  o.densify.robots.insert(densify_robots.begin(), densify_robots.end());
  cli::setThreads(o.update_threads);

  // SIGINT/SIGTERM are taken by this thread only (blocked before any other thread starts).
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  try {
    server::MapService service(o);
    server::dds_edge::DdsEdge edge(service, e);
    int sig = 0;
    sigwait(&signals, &sig);
    spdlog::info("received {}", sig == SIGINT ? "SIGINT" : "SIGTERM");
    edge.stop();
    for (const auto& [id, r] : service.statistics().robots) {
      std::printf("robot %-16s received %llu, in map %llu, dropped %llu, rejected %llu\n", id.c_str(),
                  static_cast<unsigned long long>(r.received), static_cast<unsigned long long>(r.processed),
                  static_cast<unsigned long long>(r.dropped), static_cast<unsigned long long>(r.rejected));
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
