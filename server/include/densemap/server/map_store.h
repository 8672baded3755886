// The exact occupancy map shared by the pipeline (one writer thread) and the query handlers (many
// readers). Readers hold a shared lock and never see half a scan: a scan's evidence is applied under the
// exclusive lock. The writer reads the map without a lock while it traces a scan (it is the only writer).
// Writes that queries ask for (clear box, reset) run on the writer's thread, between scans, so the
// culling region never sees the map change under it.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <shared_mutex>

#include "densemap/map/occupancy_map.h"
#include "densemap/server/latency_window.h"

namespace densemap::server {

/// A shared mutex that lets a waiting writer in before newly arriving readers (glibc's rwlock prefers
/// readers, which would let a steady query load starve the map update).
class WriterPreferringMutex {
 public:
  void lock() {
    std::lock_guard gate(gate_);
    rw_.lock();
  }
  void unlock() { rw_.unlock(); }
  void lock_shared() {
    { std::lock_guard gate(gate_); }  // wait behind a writer that is waiting
    rw_.lock_shared();
  }
  void unlock_shared() { rw_.unlock_shared(); }

 private:
  std::mutex gate_;
  std::shared_mutex rw_;
};

class MapStore {
 public:
  explicit MapStore(std::unique_ptr<map::OccupancyMap> map) : map_(std::move(map)) {}

  /// For the writer thread only: the map, read without a lock.
  map::OccupancyMap& writerView() { return *map_; }

  /// Runs f with the exclusive lock and increments the version (the writer thread).
  void write(const std::function<void(map::OccupancyMap&)>& f) {
    std::unique_lock lock(mutex_);
    const auto t0 = std::chrono::steady_clock::now();
    f(*map_);
    version_.fetch_add(1, std::memory_order_release);
    held_.add(msSince(t0));
  }

  /// Runs f on a consistent map with its version (any thread).
  template <class F>
  auto read(F&& f) const {
    const auto t0 = std::chrono::steady_clock::now();
    std::shared_lock lock(mutex_);
    waited_.add(msSince(t0));
    return f(static_cast<const map::OccupancyMap&>(*map_), version_.load(std::memory_order_acquire));
  }

  /// How long writes held the exclusive lock (what a query can wait for), in ms.
  LatencySummary exclusiveHold() const { return held_.summary(); }
  /// How long reads waited for the lock, in ms.
  LatencySummary readWait() const { return waited_.summary(); }

  std::uint64_t version() const { return version_.load(std::memory_order_acquire); }

  /// Queues a write for the writer thread and returns its result (the number of cells it changed). After
  /// writerStopped() the write runs at once on the caller's thread.
  std::future<std::uint64_t> post(std::function<std::uint64_t(map::OccupancyMap&)> command);
  /// Runs the queued commands (writer thread); true if there were any.
  bool runCommands();
  bool hasCommands() const;
  /// The writer thread has exited: run later commands inline.
  void writerStopped() {
    writer_gone_ = true;
    runCommands();
  }

 private:
  static double msSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }

  std::unique_ptr<map::OccupancyMap> map_;
  LatencyWindow held_;
  mutable LatencyWindow waited_;
  mutable WriterPreferringMutex mutex_;
  std::atomic<std::uint64_t> version_{0};
  std::atomic<bool> writer_gone_{false};
  mutable std::mutex commands_mutex_;
  std::deque<std::pair<std::function<std::uint64_t(map::OccupancyMap&)>, std::promise<std::uint64_t>>>
      commands_;
};

}  // namespace densemap::server
