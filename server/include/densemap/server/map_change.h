// A command that travels the pipeline like a scan (clear box, reset, load, and a save's snapshot), so
// every change to either layer happens on that layer's writer thread, in order with the scans: one door,
// which the journal of a later issue records. Each stage applies its part; the last one completes it.
#pragma once

#include <future>
#include <memory>
#include <string>
#include <vector>

#include "densemap/map/occupancy_map.h"
#include "densemap/server/command.h"

namespace densemap::server {

struct MapChange {
  explicit MapChange(Command c) : command(std::move(c)) {}

  Command command;
  /// LoadCommand: the decoded map the occupancy stage swaps in.
  std::unique_ptr<map::OccupancyMap> loaded;
  /// LoadCommand: the file's bytes (the journal keeps them, so a replay does not need the file).
  std::string loaded_file;
  /// SaveCommand, SnapshotCommand: the copy the occupancy stage takes (written to disk off the writer
  /// thread).
  std::unique_ptr<map::OccupancyMap> snapshot;
  /// SnapshotCommand: the last journal record before it and the robots' progress then (journal stage),
  /// and the dense layer's state (dense stage).
  std::uint64_t snapshot_lsn = 0;
  std::string snapshot_progress;
  std::string dense_state;
  /// SnapshotCommand with a map window: its state (MapWindow::snapshotState) at the snapshot's point.
  std::string window_state;
  std::vector<std::string> window_files_to_sync;  ///< synced by the snapshot's thread, not the writer
  double snapshot_ms = 0.0;                       ///< how long taking the snapshot held up the map update
  CommandResult result;
  std::promise<void> done;  ///< set when the last stage has applied it (or the pipeline gave it up)
};

}  // namespace densemap::server
