// One layer of the map (the exact map, or the dense layer) shared by its one writer thread and many
// readers. Readers run under a shared lock and see whole versions, never half a scan; the writer changes
// the layer under the exclusive lock only for the final publish (it reads its own layer without a lock,
// as it is the only writer). How long the lock is held and waited for is measured for the statistics.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <shared_mutex>

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

template <class T>
class VersionedStore {
 public:
  explicit VersionedStore(std::unique_ptr<T> value) : value_(std::move(value)) {}

  /// For the writer thread only: the layer, read without a lock.
  T& writerView() { return *value_; }

  /// Runs f(T&) under the exclusive lock and counts a new version (writer thread).
  template <class F>
  void write(F&& f) {
    std::unique_lock lock(mutex_);
    const auto t0 = std::chrono::steady_clock::now();
    f(*value_);
    version_.fetch_add(1, std::memory_order_release);
    held_.add(msSince(t0));
  }

  /// Swaps in a whole new layer (a loaded map) as a new version; the old one is destroyed after the lock.
  void replace(std::unique_ptr<T> value) {
    write([&](T&) { std::swap(value_, value); });
  }

  /// Runs f(const T&, version) on a consistent layer (any thread).
  template <class F>
  auto read(F&& f) const {
    const auto t0 = std::chrono::steady_clock::now();
    std::shared_lock lock(mutex_);
    waited_.add(msSince(t0));
    return f(static_cast<const T&>(*value_), version_.load(std::memory_order_acquire));
  }

  std::uint64_t version() const { return version_.load(std::memory_order_acquire); }
  /// How long writes held the exclusive lock (what a reader can wait for), in ms.
  LatencySummary exclusiveHold() const { return held_.summary(); }
  /// How long reads waited for the lock, in ms.
  LatencySummary readWait() const { return waited_.summary(); }

 private:
  static double msSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }

  std::unique_ptr<T> value_;
  LatencyWindow held_;
  mutable LatencyWindow waited_;
  mutable WriterPreferringMutex mutex_;
  std::atomic<std::uint64_t> version_{0};
};

}  // namespace densemap::server
