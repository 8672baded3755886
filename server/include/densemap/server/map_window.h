// The rolling window and the memory cap: after each scan, grid blocks whose centre is farther
// than the radius from every robot's latest sensor position, and then the least recently updated while
// the map is over its cap, leave the exact map's memory: kept as write-once files in the block store
// (DATA_DIR/blocks) or dropped. Before each scan, the stored blocks its rays can reach come back, so the
// map (in memory plus stored) is always the map of every scan. Runs on the map's writer thread only.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "densemap/map/block_id_map.h"
#include "densemap/map/grid_map.h"
#include "densemap/server/durability/block_store.h"
#include "densemap/server/map_window_stats.h"
#include "densemap/server/robot_places.h"
#include "densemap/server/stage_options.h"
#include "densemap/util/log_throttle.h"

namespace densemap::server {

class MapWindow {
 public:
  using Publisher = map::OccupancyMap::Publisher;
  /// `store` is used when options.store (then it must not be null).
  MapWindow(MapWindowOptions options, std::unique_ptr<durability::BlockStore> store);

  /// Before a scan whose rays lie in the key box [lo, hi] and reach `reach_m` from its origin: its stored
  /// blocks come back (inside publish).
  /// Throws durability::StorageError or util::FormatError (naming the file) when one cannot be read; then
  /// nothing changed, and the scan must not be applied (it would overwrite the stored cells).
  /// Returns how many blocks came back.
  std::size_t bringBack(map::GridMap& m, const geometry::VoxelKey& lo, const geometry::VoxelKey& hi,
                        float reach_m, const Publisher& publish);
  /// For a query (options.query_load_s > 0): the stored blocks in these key boxes come back and are kept in
  /// memory for query_load_s of map time. Same errors as bringBack. Returns how many came back.
  std::size_t bringBackForQuery(map::GridMap& m,
                                const std::vector<std::pair<geometry::VoxelKey, geometry::VoxelKey>>& boxes,
                                const Publisher& publish);
  /// After a scan of `robot` from `origin` at map time `now_s` (the scan's receive time): robots silent
  /// past the timeout are forgotten, then blocks leave memory (removed inside publish, written after).
  void afterScan(map::GridMap& m, const std::string& robot, const geometry::Vec3f& origin, double now_s,
                 const Publisher& publish);
  /// A reset or a loaded map: no block is stored any more (the files go at the next snapshot's collect).
  void forgetAll();

  /// The window's part of a snapshot: its state, and the block files it names that are not durable yet.
  struct SnapshotPart {
    std::string state;
    std::vector<std::string> files_to_sync;
  };
  /// For a snapshot (writer thread): the version counter, the robots' positions and the index of stored
  /// blocks. The files go to syncStored on the snapshot's own thread, so the writer does not wait for
  /// thousands of fsyncs (one per block that left memory since the last snapshot).
  SnapshotPart snapshotPart();
  /// Makes the files of a SnapshotPart durable; call before the snapshot that holds its state is written.
  /// Any thread. Throws durability::StorageError; the files not synced then go to the next snapshot.
  void syncStored(std::vector<std::string> files);
  /// snapshotPart with its files synced here (start-up and exit, when no other thread runs).
  std::string snapshotState();
  /// After a restart: the state of the snapshot; marks its stored blocks out of memory in `m`.
  /// Throws util::FormatError naming what is wrong.
  void restoreState(std::string_view state, map::GridMap& m);
  /// A snapshot with `state` is durable: files neither it nor the live index names can go (done on the
  /// writer thread at the next scan). Any thread.
  void snapshotWritten(std::string state);

  using Stats = MapWindowStats;
  Stats stats() const;
  const MapWindowOptions& options() const { return options_; }

 private:
  void evict(map::GridMap& m, const std::vector<std::uint64_t>& ids, const Publisher& publish);
  std::size_t bringBackIds(map::GridMap& m, const std::vector<std::uint64_t>& ids, const Publisher& publish);
  void collectPending();
  /// Drops pins whose time is over (now_s: map time) and the ids still pinned from `ids`.
  void unpin(double now_s, std::vector<std::uint64_t>& ids);

  MapWindowOptions options_;
  std::unique_ptr<durability::BlockStore> store_;
  RobotPlaces robots_{options_.robot_timeout_s};                   // latest sensor position per robot
  double last_scan_s_ = std::numeric_limits<double>::quiet_NaN();  // map time of the latest scan
  // Blocks a query brought back -> map time until which they stay (NaN: from the next scan on).
  std::unordered_map<std::uint64_t, double> pinned_;
  map::BlockIdMap<std::uint64_t> index_;  // stored block -> version
  std::uint64_t version_ = 0;
  std::mutex pending_mutex_;
  std::optional<std::string> pending_collect_;
  std::vector<std::string> resync_;  // files a failed syncStored left for the next snapshot
  std::atomic<std::uint64_t> blocks_out_{0}, left_{0}, came_back_{0}, dropped_{0}, bytes_stored_{0},
      store_failures_{0}, robots_forgotten_{0}, loaded_for_queries_{0};
  util::LogThrottle throttle_;
  util::LogThrottle thrash_throttle_{std::chrono::seconds(60)};  // a lasting condition: once a minute
};

}  // namespace densemap::server
