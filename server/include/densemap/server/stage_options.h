// The options of the service's parts (pipeline, stages, limits, window), in one header without code, so
// that ServiceOptions and the option table need none of the parts' own headers.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace densemap::server {

enum class OverflowPolicy {
  kWait,        ///< the producer blocks until there is room (back-pressure; nothing is lost)
  kDropOldest,  ///< the oldest queued item is dropped (bounded latency; every drop is counted)
};

struct PipelineOptions {
  /// Scans each robot may have waiting before the overflow policy applies.
  std::size_t robot_queue_capacity = 8;
  /// What happens when a robot's queue is full: wait (the robot is slowed down through DDS's reliable
  /// flow control, nothing is lost) or drop the oldest waiting scan (counted).
  OverflowPolicy overflow = OverflowPolicy::kWait;
  /// Scans waiting between two stages.
  std::size_t stage_queue_capacity = 2;
  /// At most this many robots are served; scans from further robot ids are rejected.
  std::size_t max_robots = 256;
};

struct DensifyOptions {
  std::string method = "none";  ///< none, iln (the trained network) or bilinear (the baseline)
  std::string weights;          ///< ILN weights; empty: the shipped compact model (models/iln/iln_compact.pt)
  /// Scans from a LiDAR with this many beams are densified (0: any scan that carries its geometry)...
  int input_rows = 16;
  /// ...or, when not empty, exactly the scans of these robots (they must carry their LiDAR geometry).
  std::vector<std::string> robots;
  /// Output beams and columns (0: the input's columns). Beam spacing is the input's divided by
  /// rows / input rows, from the same top beam, so every input beam is an output beam (16 -> 64 reproduces
  /// the KITTI HDL-64E layout from its every 4th beam).
  int target_rows = 64;
  int target_columns = 0;
  int threads = 2;  ///< libtorch and inference threads
};

struct ScanLimits {
  /// Scans with more points are rejected (a 128x2048 LiDAR gives 262,144).
  std::size_t max_points = 1'000'000;
  /// Largest accepted | |q| - 1 | of the pose quaternion (senders should normalise; rounding is tolerated).
  double quaternion_tolerance = 1e-3;
};

struct QueryLimits {
  /// Most points in one points query.
  std::size_t max_points = 1'000'000;
  /// Cells a box query returns when its limit is 0, and the most it may ask for.
  std::uint32_t default_box_limit = 100'000;
  std::uint32_t max_box_limit = 2'000'000;
  /// Longest ray a ray query may cast, in metres.
  double max_ray_range = 1000.0;
};

struct MapWindowOptions {
  double radius_m = 0.0;    ///< 0: no window
  double max_map_mb = 0.0;  ///< 0: no cap
  bool store = true;        ///< false: blocks that leave memory are forgotten
  /// A robot whose last scan is this much map time old no longer keeps blocks in memory (0: never).
  double robot_timeout_s = 300.0;
  /// > 0: a query that reaches stored blocks brings them back, and they stay in memory this many seconds of
  /// map time (the scans' receive time) before they may leave again; 0: the query says "not in memory".
  double query_load_s = 0.0;
  /// False without a journal: no snapshot will name a file, so a block's file goes as soon as it comes back.
  bool snapshots = true;
  bool enabled() const { return radius_m > 0.0 || max_map_mb > 0.0; }
};

}  // namespace densemap::server
