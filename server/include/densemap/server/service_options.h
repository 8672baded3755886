// Everything the mapping service (MapService, no transport) is configured with, with its defaults. Names,
// ranges and help are declared once, in the option tables (service_option_table.cpp), from which the flags,
// the configuration file keys, --help and config/server.toml come.
#pragma once

#include <string>

#include "densemap/dense/dense_layer_factory.h"
#include "densemap/map/map_factory.h"
#include "densemap/server/durability/durability_options.h"
#include "densemap/server/stage_options.h"
#include "densemap/update/update_engine.h"

namespace densemap::server {

struct ServiceOptions {
  /// Names this server in statistics and logs.
  std::string server_id = "densemap-server";
  map::MapOptions map{};
  update::UpdateOptions update{};  ///< super rays + culling region, batch semantics by default
  PipelineOptions pipeline{};
  dense::DenseLayerOptions dense{};
  /// Nice value of the dense stage's threads (0..19). It drops scans instead of falling behind, so it never
  /// needs its priority back: 19 lets queries and the exact map go first (lowering needs no privilege).
  int dense_nice = 19;
  DensifyOptions densify{};  ///< ILN densify before the occupancy update (off by default)
  /// Threads of the map update (OpenMP); 0 = all cores.
  int update_threads = 0;
  /// Times an idle OpenMP worker spins before it sleeps (GOMP_SPINCOUNT; -1: libgomp's default, ~300,000
  /// spins; 13% of the server's samples at 5 robots, docs/BENCHMARKS.md). libgomp reads it before main, so
  /// the server re-executes itself once to apply it (openmp_idle_spin.h); OMP_WAIT_POLICY or GOMP_SPINCOUNT
  /// in the environment win.
  int update_idle_spin = 0;
  ScanLimits limits{};
  QueryLimits queries{};
  /// Nice value of the map update's threads while scans are on time (0..19; -1 = auto: 19 if this
  /// process may raise the priority back, else 0). Above 0, query and DDS threads take a core as soon as
  /// they wake instead of waiting for the update's time slice. A scan that is late (see update_catch_up_ms)
  /// is updated at normal priority, so a query load cannot starve the map; that needs the right to raise a
  /// priority back (root, CAP_SYS_NICE or RLIMIT_NICE >= 20), without which a value > 0 stays in force.
  int update_nice = -1;
  /// A scan is late this many milliseconds after the server took it in.
  int update_catch_up_ms = 100;
  /// Nice value of a late scan's update (-20..0; needs update_nice > 0). 0: an equal share with the query
  /// threads. Below 0 the map falls less far behind under a flood of queries, at the cost of their
  /// latency (-10 with four back-to-back clients on 2 cores: map lag p50 175-179 ms instead of 189-518,
  /// query p99 ~22 ms instead of ~10; docs/BENCHMARKS.md). Going below 0 needs root, CAP_SYS_NICE or
  /// RLIMIT_NICE >= 20 - value; without it the server keeps 0 and says so.
  int update_late_nice = 0;
  /// The dense stage's input when it falls behind: drop the oldest scans, or wait (every scan reaches it).
  OverflowPolicy dense_overflow = OverflowPolicy::kDropOldest;
  /// The rolling window and the memory cap of the exact map (grid backend; off by default).
  MapWindowOptions window{};
  /// The journal and snapshots in DATA_DIR (docs/DURABILITY.md).
  durability::DurabilityOptions durability{};
  /// The service's data directory (the journal, snapshots, and maps).
  std::string data_dir = "densemap-data";
  /// Where save and load requests read and write (a request names a file, never a path); empty:
  /// DATA_DIR/maps.
  std::string map_dir;
  /// Largest map file a load reads.
  std::size_t max_map_file_bytes = std::size_t{2} << 30;
  /// On shutdown: drop queued scans, counted (true), instead of mapping them first.
  bool drop_on_exit = false;
  /// On shutdown, save the map here (a path chosen by the operator, .bt or .ot); empty: do not save.
  std::string save_on_exit;
};

}  // namespace densemap::server
