// Everything densemap-server can be configured with, with documented defaults. The command line and the
// configuration file (TOML, same names as the long flags) fill this in one place (server_cli.cpp).
#pragma once

#include <string>

#include "densemap/map/occupancy_params.h"
#include "densemap/msg/dds_node.h"
#include "densemap/server/densify_stage.h"
#include "densemap/server/pipeline.h"
#include "densemap/server/query_service.h"
#include "densemap/server/scan_validator.h"
#include "densemap/update/update_engine.h"

namespace densemap::server {

struct MapOptions {
  std::string backend = "grid";   ///< "grid" (hashed dense blocks, fastest) or "octree" (OctoMap's OcTree)
  double resolution = 0.2;        ///< voxel edge in metres
  map::OccupancyParams params{};  ///< OctoMap's sensor model defaults
};

/// The dense layer stage (Ch. 3), after the exact map.
struct DenseLayerOptions {
  std::string method = "none";  ///< "none", "akimap" or "bgk"
  double resolution = 0.0;      ///< cell size; 0: the map's resolution
  double free_sample_distance = 0.5;
  /// One free sample per voxel of this size (0: the resolution). 0.3 keeps a 64-beam LiDAR at ~226 ms per
  /// scan at 0.2 m (docs/BENCHMARKS.md).
  double free_voxel_size = 0.3;
  double max_range = 30.0;
  /// Nice value of the stage's threads (0..19). It drops scans instead of falling behind, so it never
  /// needs its priority back: 19 lets queries and the exact map go first (lowering needs no privilege).
  int nice = 19;
  /// AKIMap extensions (dense/adaptive_kernel_layer.h): isotropic free kernels, occupied radius floor.
  bool isotropic_free_kernels = false;
  double min_occupied_search_radius =
      0.0;  ///< rays are cut here for the dense layer (metres; < 0: unlimited)
};

struct ServerOptions {
  msg::DdsOptions dds{};
  /// Names this server in statistics and logs.
  std::string server_id = "densemap-server";
  MapOptions map{};
  update::UpdateOptions update{};  ///< super rays + culling region, batch semantics by default
  PipelineOptions pipeline{};
  DenseLayerOptions dense{};
  DensifyOptions densify{};  ///< ILN densify before the occupancy update (off by default)
  ScanLimits limits{};
  QueryLimits queries{};
  /// Threads answering queries concurrently with the map update.
  int query_threads = 2;
  /// Threads of the map update (OpenMP); 0 = all cores.
  int update_threads = 0;
  /// Nice value of the map update's threads while scans are on time (0..19; -1 = auto: 19 if this
  /// process may raise the priority back, else 0). Above 0, query and DDS threads take a core as soon as
  /// they wake instead of waiting for the update's time slice. A scan that is late (see update_catch_up_ms)
  /// is updated at normal priority, so a query load cannot starve the map; that needs the right to raise a
  /// priority back (root, CAP_SYS_NICE or RLIMIT_NICE >= 20), without which a value > 0 stays in force.
  int update_nice = -1;
  /// A scan is late this many milliseconds after the server took it from DDS.
  int update_catch_up_ms = 100;
  /// Nice value of a late scan's update (-20..0; needs update_nice > 0). 0: an equal share with the query
  /// threads. Below 0 the map falls less far behind under a flood of queries, at the cost of their
  /// latency (-10 with four back-to-back clients on 2 cores: map lag p50 175-179 ms instead of 189-518,
  /// query p99 ~22 ms instead of ~10; docs/BENCHMARKS.md). Going below 0 needs root, CAP_SYS_NICE or
  /// RLIMIT_NICE >= 20 - value; without it the server keeps 0 and says so.
  int update_late_nice = 0;
  /// Scheduler time slice in microseconds asked for the DDS, query and other latency-bound threads (Linux
  /// >= 6.12 honours it; 0 = the kernel's default). The pipeline's stages keep the default.
  int latency_slice_us = 100;
  /// SCHED_FIFO priority (1..99) of the DDS receive threads (which answer point and ray queries) and the
  /// query threads; 0 = normal scheduling. On a busy 2-core machine it keeps the nice-19 map update from
  /// parking a query mid-answer until the next timer tick. With the query client at the same priority
  /// (densemap-replay --realtime-priority; kitti00 at 10 Hz, 1,000-point queries at 100 Hz) the round
  /// trip p99 was 1.7-4.4 ms in ten runs against 3.9-6.7 ms without (docs/BENCHMARKS.md). The map update,
  /// scan intake and statistics never run real-time. Off by default: real-time threads answering a flood
  /// of box queries could take every core from the map. Needs root, CAP_SYS_NICE or RLIMIT_RTPRIO >= the
  /// value; without it the server says so and runs normally.
  int realtime_priority = 0;
  /// Seconds between statistics messages (and log lines); 0 disables them.
  double statistics_period_s = 1.0;
  /// On shutdown: process every queued scan (true) or drop them, counted (false).
  bool drain_on_exit = true;
  /// On shutdown, save the map here (.bt or .ot); empty: do not save.
  std::string save_on_exit;
};

}  // namespace densemap::server
