#include "densemap/server/service_statistics.h"

#include <unistd.h>

#include <fstream>

#include <fmt/format.h>

namespace densemap::server {

RobotCounters ServiceStatistics::totals() const {
  RobotCounters t;
  for (const auto& [id, r] : robots) {
    t.received += r.received;
    t.processed += r.processed;
    t.dropped += r.dropped;
    t.rejected += r.rejected;
    t.duplicates += r.duplicates;
    t.durable_scans += r.durable_scans;
    t.journaled_scans += r.journaled_scans;
    t.points_rejected += r.points_rejected;
  }
  return t;
}

std::string ServiceStatistics::summaryLine() const {
  const RobotCounters t = totals();
  std::string stage_text;
  for (const auto& st : stages) {
    stage_text += fmt::format("; {} p50 {:.2f} p99 {:.2f} ms", st.name, st.latency.p50_ms, st.latency.p99_ms);
    if (st.dropped > 0) stage_text += fmt::format(" ({} scans skipped: behind)", st.dropped);
  }
  std::string methods;
  for (const auto& [method, scans] : update_methods)
    if (scans > 0) methods += fmt::format("{}{} {}", methods.empty() ? "" : ", ", method, scans);
  if (!methods.empty()) stage_text += fmt::format(" (update method {}: {})", update_method, methods);
  return fmt::format(
             "{} robots: {} scans received, {} in map, {} dropped, {} rejected; publish-to-map p50 {:.1f} ms "
             "p99 {:.1f} ms; map {:.1f} MB; resident {:.0f} MB (heap {:.0f} MB in use, {:.0f} MB free in the "
             "allocator); {} queries{}",
             robots.size(), t.received, t.processed, t.dropped, t.rejected, publish_to_map.p50_ms,
             publish_to_map.p99_ms, static_cast<double>(memory_bytes) / 1e6,
             static_cast<double>(resident_bytes) / 1e6, static_cast<double>(heap_in_use_bytes) / 1e6,
             static_cast<double>(heap_free_bytes) / 1e6, queries_answered, stage_text) +
         (durability.enabled
              ? fmt::format(
                    "; journal: {} durable scans, {} resends refused, {:.1f} MB, {} fsyncs (p99 {:.1f} ms), "
                    "{} snapshots{}",
                    t.durable_scans, t.duplicates, static_cast<double>(durability.bytes) / 1e6,
                    durability.syncs, durability.sync_ms.p99_ms, durability.snapshots,
                    durability.failed ? "; FAILED: " + durability.last_error : std::string())
              : std::string("; journal off")) +
         (window ? fmt::format(
                       "; window: {} blocks out of memory, {} left, {} came back, {} loaded for queries, "
                       "{} store failures",
                       window->blocks_out, window->left, window->came_back, window->loaded_for_queries,
                       window->store_failures)
                 : std::string());
}

std::uint64_t residentBytes() {
  std::ifstream statm("/proc/self/statm");
  std::uint64_t size = 0, resident = 0;
  statm >> size >> resident;
  return resident * static_cast<std::uint64_t>(sysconf(_SC_PAGESIZE));
}

}  // namespace densemap::server
