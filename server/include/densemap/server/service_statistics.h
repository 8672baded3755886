// Everything the service reports about itself, assembled in one place (MapService::statistics()); the
// edges publish it and the server logs it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "densemap/server/latency_window.h"
#include "densemap/server/pipeline.h"

namespace densemap::server {

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

  /// Totals over the robots.
  RobotCounters totals() const;
  /// One log line (robots, scans, latencies, stages).
  std::string summaryLine() const;
};

/// The process's resident memory (from /proc/self/statm; 0 where unavailable).
std::uint64_t residentBytes();

}  // namespace densemap::server
