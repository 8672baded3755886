// A scan on its way through the server's pipeline, in core types (each edge converts once).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "densemap/io/scan.h"

namespace densemap::server {

struct MapChange;
struct ScanJob;

/// kDuplicate: the (robot, seq) pair is in the map already (a resend); it is durable and not applied again.
enum class ScanOutcome { kInMap, kRejected, kDropped, kDuplicate };

/// Hears a scan's final outcome once (on a pipeline thread, or the submitting one for rejections at the
/// door); `why` explains rejections and drops. It must not block: the edges queue their acknowledgements.
using OutcomeCallback = std::function<void(const ScanJob& job, ScanOutcome outcome, const std::string& why)>;

/// A scan (or, when `change` is set, a command in the scans' order) on its way through the pipeline.
struct ScanJob {
  std::string robot_id;
  std::uint64_t seq = 0;
  std::int64_t publish_ns = 0;   ///< when the robot published it (system clock)
  std::int64_t received_ns = 0;  ///< when the server took it from DDS
  /// The pose as sent: position and quaternion (w, x, y, z), checked by validateScan before use.
  std::array<double, 3> position{0, 0, 0};
  std::array<double, 4> quaternion{1, 0, 0, 0};
  /// Sensor-frame points; scan.pose is set by validateScan.
  io::Scan scan;
  std::uint32_t points_rejected = 0;  ///< non-finite or out-of-key-range points removed
  std::uint64_t map_version = 0;      ///< map version once the scan is in the map
  std::int64_t in_map_ns = 0;         ///< when the scan was in the map (system clock)
  bool durable = false;               ///< in the journal and synced (set by the journal stage)
  std::shared_ptr<MapChange> change;  ///< set: this job is a command, not a scan
  OutcomeCallback on_outcome;         ///< the submitting edge's, called once with the outcome
};

}  // namespace densemap::server
