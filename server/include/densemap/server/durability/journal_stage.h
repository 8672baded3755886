// The journal as the pipeline stage before the exact map: it appends every scan and every command that
// changes a layer, makes the group durable with one fsync, and only then lets it reach the map, so the map
// never holds what the disk does not and an acknowledgement always means durable. It also refuses a
// (robot, seq) pair that is journaled already (a resend), so a pair is applied at most once.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>

#include "densemap/server/durability/journal_segment.h"
#include "densemap/server/durability/robot_progress.h"
#include "densemap/server/latency_window.h"
#include "densemap/server/pipeline_stage.h"

namespace densemap::server::durability {

struct JournalCounters {
  std::uint64_t records = 0;     ///< appended this run
  std::uint64_t bytes = 0;       ///< appended this run
  std::uint64_t syncs = 0;       ///< fsyncs this run
  std::uint64_t duplicates = 0;  ///< resends refused (already journaled)
  std::uint64_t failures = 0;    ///< scans and commands refused because the journal could not take them
  std::uint64_t last_lsn = 0;
  std::uint64_t scans_since_snapshot = 0;
  bool failed = false;  ///< an fsync failed: no more scans until a restart
  std::string last_error;
  LatencySummary sync_ms;  ///< how long one fsync took
};

class JournalStage : public PipelineStage {
 public:
  /// `journaled`: the progress recovered from the data directory (everything in it is durable).
  /// `since_snapshot`: records replayed at start-up (after the newest snapshot), so a server that crashes
  /// often still reaches its next snapshot.
  JournalStage(std::unique_ptr<JournalWriter> writer, RobotProgress journaled, int sync_ms,
               std::uint64_t since_snapshot = 0);

  std::string name() const override { return "journal"; }
  std::optional<std::chrono::microseconds> groupWindow() const override { return window_; }
  StageResult process(ScanJob& job) override;
  void processGroup(std::vector<ScanJob>& jobs, std::vector<StageResult>& results) override;

  /// The highest durable sequence number of a robot (any thread).
  std::optional<std::uint64_t> lastDurableSeq(const std::string& robot) const;
  /// A copy of every robot's durable progress (any thread).
  RobotProgress durableProgress() const;
  JournalCounters counters() const;
  std::uint64_t scansSinceSnapshot() const { return scans_since_snapshot_.load(); }

 private:
  std::unique_ptr<JournalWriter> writer_;
  RobotProgress journaled_;  // this stage's thread only
  mutable std::mutex durable_mutex_;
  RobotProgress durable_;  // what is synced, for the edges
  std::chrono::microseconds window_;
  std::atomic<std::uint64_t> duplicates_{0}, failures_{0}, scans_since_snapshot_{0};
  mutable std::mutex error_mutex_;
  std::string last_error_;
  LatencyWindow sync_ms_;
};

}  // namespace densemap::server::durability
