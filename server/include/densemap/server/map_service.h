// The mapping service without any transport: owns the two layers, the scan pipeline (densify -> exact
// occupancy update -> dense layer), query answering and commands. Edges (DDS, ROS 2) convert their
// messages to the types below and call these five functions; nothing here knows DDS or libtorch.
//
// One door for changes: scans, clear box, reset and load all reach a layer through that layer's writer
// thread, in one order (the pipeline), which a journal can record and replay exactly.
#pragma once

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "densemap/server/command.h"
#include "densemap/server/durability/data_directory.h"
#include "densemap/server/durability/journal_stage.h"
#include "densemap/server/latency_window.h"
#include "densemap/server/map_directory.h"
#include "densemap/server/map_stores.h"
#include "densemap/server/map_window.h"
#include "densemap/server/pipeline.h"
#include "densemap/server/query.h"
#include "densemap/server/query_answerer.h"
#include "densemap/server/service_options.h"
#include "densemap/server/service_statistics.h"

namespace densemap::server {

class OccupancyStage;
class DenseStage;

/// What submit() did with a scan at the door.
struct SubmitResult {
  bool accepted = false;  ///< queued; its final outcome comes through the outcome listener
  std::string why;        ///< when not accepted (rejected at the door: also reported to the listener)
};

class MapService {
 public:
  /// Builds the layers, recovers them from the data directory (newest snapshot + the journal after it),
  /// and starts the pipeline's threads. Throws std::invalid_argument (with a message naming the option),
  /// durability::RecoveryError (a data directory that cannot be used as it is: the message says what to
  /// do) or std::runtime_error (e.g. a missing ILN weights file).
  explicit MapService(ServiceOptions options);
  ~MapService();
  MapService(const MapService&) = delete;
  MapService& operator=(const MapService&) = delete;

  /// Validates the scan and queues it (may block under the wait overflow policy). `on_outcome` hears the
  /// scan's final outcome exactly once (a rejection at the door included), on a pipeline thread.
  SubmitResult submit(ScanJob job, OutcomeCallback on_outcome = {});
  /// Counts and reports a scan an edge could not convert (malformed as a message), like a rejection.
  void refuse(const ScanJob& job, const std::string& why, const OutcomeCallback& on_outcome = {});
  /// Answers from a consistent state of the map; never throws.
  Answer answer(const Query& query);
  /// Runs a command; changes go through the writer threads in order with the scans; never throws.
  /// `requester` names who asked, for the log.
  CommandResult execute(const Command& command, const std::string& requester = "");
  /// Counts a query or a command an edge refused before it could be one (unknown kind, malformed), so
  /// the statistics count every request.
  void countRefusedQuery() { answerer_->countFailure(); }
  /// Counts a query an edge answered kBusy (its backlog was full) without asking the service.
  void countBusyQuery() { answerer_->countBusy(); }
  void countRefusedCommand() { ++commands_failed_; }
  ServiceStatistics statistics() const;
  /// Stops taking scans; with `drain` maps every queued scan, else drops them (counted); saves if
  /// configured. Idempotent.
  void stop(bool drain);
  void stop() { stop(!options_.drop_on_exit); }

  const ServiceOptions& options() const { return options_; }
  /// Reads the exact map / the dense layer (tests, benchmarks). The dense store is null without one.
  const MapStore& mapStore() const { return *store_; }
  const DenseStore* denseStore() const { return dense_store_.get(); }
  const MapDirectory& mapDirectory() const { return *map_dir_; }

  /// The highest durable sequence number of a robot (nullopt: none, or the journal is off).
  std::optional<std::uint64_t> lastDurableSeq(const std::string& robot_id) const;
  /// Every robot's durable progress (empty with the journal off).
  durability::RobotProgress durableProgress() const;
  /// What the start-up recovery found (nullopt with the journal off).
  const std::optional<durability::RecoveryReport>& recovery() const { return recovery_; }

 private:
  CommandResult snapshot();
  void snapshotLoop();
  void snapshotOnExit();
  /// Both layers as they are now, read directly (no pipeline thread may be running): recovery, exit.
  durability::SnapshotContents snapshotOfLayers(std::uint64_t lsn, std::string progress) const;
  std::unique_ptr<durability::JournalStage> recoverInto(OccupancyStage& occupancy, DenseStage* dense);
  CommandResult runChange(std::shared_ptr<MapChange> change);
  /// --window-query-load-s: most load-and-answer-again rounds per query (a ray may cross many stored blocks).
  static constexpr int kQueryLoadRounds = 16;
  std::atomic<std::uint64_t> query_loads_failed_{0};
  CommandResult save(const SaveCommand& c);
  CommandResult load(const LoadCommand& c);

 public:
  /// The map window's figures (null without one).
  std::optional<MapWindow::Stats> windowStats() const;

 private:
  ServiceOptions options_;
  std::chrono::steady_clock::time_point started_;
  std::unique_ptr<MapStore> store_;
  std::unique_ptr<MapWindow> window_;
  const OccupancyStage* occupancy_stage_ = nullptr;  // the pipeline's (method counts for the statistics)
  const DenseStage* dense_stage_ = nullptr;  // the pipeline's, when there is a dense layer  // before the
                                             // pipeline, whose occupancy stage uses it
  std::unique_ptr<DenseStore> dense_store_;
  std::unique_ptr<MapDirectory> map_dir_;
  std::unique_ptr<QueryAnswerer> answerer_;
  std::unique_ptr<Pipeline> pipeline_;
  LatencyWindow snapshot_ms_;
  std::unique_ptr<durability::DataDirectory> data_dir_;
  durability::JournalStage* journal_ = nullptr;  // owned by the pipeline
  std::optional<durability::RecoveryReport> recovery_;
  std::mutex snapshot_mutex_;  // one snapshot at a time
  std::chrono::steady_clock::time_point last_snapshot_;
  std::atomic<std::uint64_t> snapshots_written_{0}, snapshot_failures_{0}, last_snapshot_lsn_{0},
      last_snapshot_bytes_{0};
  LatencyWindow snapshot_write_ms_;
  std::mutex snapshot_loop_mutex_;
  std::condition_variable snapshot_loop_wake_;
  bool snapshot_loop_stop_ = false;
  std::thread snapshot_thread_;
  std::atomic<std::uint64_t> commands_done_{0}, commands_failed_{0};
  std::mutex stop_mutex_;
  bool stopped_ = false;
};

}  // namespace densemap::server
