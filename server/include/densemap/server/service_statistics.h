// Everything the service reports about itself, assembled in one place (MapService::statistics()); the
// edges publish it and the server logs it.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "densemap/server/latency_window.h"
#include "densemap/server/map_window_stats.h"
#include "densemap/server/pipeline.h"

namespace densemap::server {

/// The journal and the snapshots (all zero with the journal off).
struct DurabilityStatistics {
  bool enabled = false;
  std::uint64_t records = 0, bytes = 0, syncs = 0;  ///< journaled this run
  std::uint64_t duplicates = 0;                     ///< resends refused as in the map already
  std::uint64_t failures = 0;                       ///< scans and commands the journal could not take
  bool failed = false;                              ///< an fsync failed: scans are refused until a restart
  std::string last_error;
  std::uint64_t last_lsn = 0;
  std::uint64_t snapshots = 0, snapshot_failures = 0, snapshot_lsn = 0, snapshot_bytes = 0;
  std::uint64_t recovered_records = 0;  ///< journal records replayed at start-up
  double recovery_s = 0.0;
  LatencySummary sync_ms, snapshot_ms;
};

struct ServiceStatistics {
  std::string server_id;
  std::int64_t stamp_ns = 0;  ///< system clock
  double uptime_s = 0.0;
  std::vector<std::pair<std::string, RobotCounters>> robots;
  /// The pipeline's stages, then pseudo-stages: "queries" (answering, lock waits included),
  /// "map-publish" (how long a write holds readers out of the map), "map-read-wait" (how long reads
  /// waited for it) and "map-snapshot" (how long a save's copy held up the map update).
  std::vector<StageCounters> stages;
  // Cheap map figures (the periodic report must not iterate the map).
  std::string backend;
  double resolution = 0.0;
  std::uint64_t map_version = 0;
  std::uint64_t memory_bytes = 0;
  LatencySummary publish_to_map;
  std::uint64_t queries_answered = 0;
  std::uint64_t queries_failed = 0;
  std::uint64_t queries_busy = 0;  ///< answered kBusy by an edge whose backlog was full
  std::uint64_t commands_done = 0;
  std::uint64_t commands_failed = 0;
  std::uint64_t resident_bytes = 0;
  std::uint64_t heap_in_use_bytes = 0;  ///< live in the allocator (util::heapUsage)
  std::uint64_t heap_free_bytes = 0;    ///< freed, held by the allocator (util::HeapUsage)
  DurabilityStatistics durability;
  std::optional<MapWindowStats> window;  ///< with --window-radius or --max-map-mb
  std::string update_method;             ///< --method (fastest, or the forced one)
  /// Scans the exact update ran with each method this run, in update::kAllMethods' order.
  std::vector<std::pair<std::string, std::uint64_t>> update_methods;

  /// Totals over the robots.
  RobotCounters totals() const;
  /// One log line (robots, scans, latencies, stages).
  std::string summaryLine() const;
};

/// The process's resident memory (from /proc/self/statm; 0 where unavailable).
std::uint64_t residentBytes();

}  // namespace densemap::server
