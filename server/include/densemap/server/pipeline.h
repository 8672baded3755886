// The scan pipeline: a bounded queue per robot, served round-robin, then a chain of stages, each on its
// own worker thread with a bounded input queue. Every scan ends in exactly one outcome (in the map,
// rejected, or dropped) reported to the listener, and is counted per robot.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "densemap/server/bounded_queue.h"
#include "densemap/server/latency_window.h"
#include "densemap/server/pipeline_stage.h"
#include "densemap/server/scan_job.h"
#include "densemap/server/stage_options.h"

namespace densemap::server {

struct RobotCounters {
  std::uint64_t received = 0;
  std::uint64_t processed = 0;  ///< in the map
  std::uint64_t dropped = 0;
  std::uint64_t rejected = 0;
  std::uint64_t duplicates = 0;  ///< resends of scans in the map already (durable, not applied again)
  std::uint64_t points_rejected = 0;
  std::uint64_t last_seq = 0;
  // From the journal, over every run of the server (0 with the journal off):
  std::uint64_t durable_scans = 0;     ///< distinct sequence numbers in the map, durable
  std::uint64_t journaled_scans = 0;   ///< scan records journaled (durable_scans unless one came twice)
  std::uint64_t last_durable_seq = 0;  ///< the highest durable sequence number (valid when durable_scans > 0)
  std::size_t queue_depth = 0;
  std::size_t queue_capacity = 0;
};

struct StageCounters {
  std::string name;
  std::uint64_t processed = 0;
  std::uint64_t dropped = 0;
  std::size_t queue_depth = 0;
  LatencySummary latency;
};

class Pipeline {
 public:
  /// Called once per scan with its outcome (besides the scan's own on_outcome), on a pipeline thread or
  /// the submitting thread for drops and rejections at the door; `why` explains rejections and drops.
  using OutcomeListener = OutcomeCallback;

  Pipeline(PipelineOptions options, std::vector<std::unique_ptr<PipelineStage>> stages,
           OutcomeListener listener = {});
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  /// Queues a scan (validated by the caller). May block under the wait policy; returns false after stop()
  /// (and leaves `job` as it was).
  bool submit(ScanJob&& job);
  /// Counts a scan rejected before it entered the pipeline (bad input) and reports it to the listener.
  void rejectAtDoor(const ScanJob& job, const std::string& why);
  /// Queues a command ahead of the robots' waiting scans (after the scans already in a stage); every stage
  /// applies it in turn and the last completes `change->done`. False after stop().
  bool submitChange(std::shared_ptr<MapChange> change);

  /// Stops accepting scans; with `drain`, every queued scan is processed first, else queued scans are
  /// dropped (counted). Joins the workers. Idempotent.
  void stop(bool drain);

  std::map<std::string, RobotCounters> robotCounters() const;
  std::vector<StageCounters> stageCounters() const;
  LatencySummary publishToMapLatency() const { return publish_to_map_.summary(); }
  /// Scans submitted and not yet finished.
  std::uint64_t inFlight() const { return in_flight_.load(); }

 private:
  struct Robot {
    explicit Robot(const PipelineOptions& o) : queue(o.robot_queue_capacity, o.overflow) {}
    BoundedQueue<ScanJob> queue;
    RobotCounters counters;  // guarded by Pipeline::robots_mutex_
  };
  struct Stage {
    Stage(std::unique_ptr<PipelineStage> s, std::size_t capacity)
        : impl(std::move(s)),
          input(capacity, impl->inputPolicy(), [](const ScanJob& j) { return j.change != nullptr; }) {}
    std::unique_ptr<PipelineStage> impl;
    BoundedQueue<ScanJob> input;
    std::atomic<std::uint64_t> processed{0}, dropped{0};
    LatencyWindow latency;
    std::thread worker;
  };

  Robot* robot(const std::string& id);
  std::optional<ScanJob> nextRoundRobin();
  void runStage(std::size_t index);
  /// The stage's next job (the round robin for the first stage), waiting up to `timeout`; sets `finished`
  /// once its input is closed and empty.
  std::optional<ScanJob> next(std::size_t index, std::chrono::microseconds timeout, bool& finished);
  /// Hands a job the stage is done with on: to the next stage, or to its outcome.
  void pass(std::size_t index, ScanJob&& job, const StageResult& result);
  void finish(const ScanJob& job, ScanOutcome outcome, const std::string& why);

  PipelineOptions options_;
  OutcomeListener listener_;
  std::vector<std::unique_ptr<Stage>> stages_;
  mutable std::mutex robots_mutex_;
  std::map<std::string, std::unique_ptr<Robot>> robots_;
  std::vector<Robot*> order_;  // round-robin order
  std::size_t next_robot_ = 0;
  std::deque<std::shared_ptr<MapChange>> changes_;  // guarded by robots_mutex_
  std::mutex arrival_mutex_;
  std::condition_variable arrival_;
  std::atomic<bool> accepting_{true}, draining_{true}, stopped_{false};
  std::atomic<std::uint64_t> in_flight_{0};
  std::atomic<std::size_t> stages_running_{0};
  LatencyWindow publish_to_map_;
  std::mutex stop_mutex_;
};

}  // namespace densemap::server
