// The map update's CPU priority: low while scans are on time, so query and DDS threads take a core as
// soon as they wake; normal as soon as a scan is late, so a query load can never starve the map.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace densemap::server {

struct UpdatePriorityOptions {
  /// Nice value of the update's threads while scans are on time (0..19; 0 = always normal priority).
  int low_nice = 19;
  /// A scan is late this long after the server took it from DDS: from then on its update runs at
  /// `late_nice` (the threads are re-niced mid-scan if need be).
  std::chrono::milliseconds catch_up{100};
  /// Nice value of a late scan's update (-20..0). 0: an equal share of the cores with the query threads.
  /// Below 0 it takes more, which bounds how far the map falls behind under a flood of queries (and
  /// costs those queries' latency); going below 0 needs root, CAP_SYS_NICE or RLIMIT_NICE >= 20 - value.
  int late_nice = 0;
};

/// The priority policy for the configured values (update_nice -1: 19 if this process may raise it back,
/// else 0), saying in the log what it chose and why. The values are in range (the option table checks).
UpdatePriorityOptions resolveUpdatePriority(int update_nice, int catch_up_ms, int late_nice);

/// Thread ids of the calling thread and its OpenMP team (libgomp keeps one persistent team per thread that
/// starts parallel regions, and its threads take their nice value only at creation, so a priority is set
/// on each).
std::vector<int> openmpTeamThreadIds();
/// Sets the nice value of each thread; false if any refused.
bool setThreadsNice(const std::vector<int>& thread_ids, int nice);

class UpdatePriority {
 public:
  /// True if this process may raise a thread's priority back to nice `to` (0: root, CAP_SYS_NICE or
  /// RLIMIT_NICE >= 20, e.g. `ulimit -e 20`). Without it a lowered priority could never be undone.
  static bool canRaisePriority(int to = 0);

  explicit UpdatePriority(UpdatePriorityOptions options);
  ~UpdatePriority();
  UpdatePriority(const UpdatePriority&) = delete;
  UpdatePriority& operator=(const UpdatePriority&) = delete;

  /// Runs `update` on the calling thread and its OpenMP team: at the low priority until `late_at`, at
  /// `late_nice` from then on; afterwards the team is back at the low priority.
  void run(std::chrono::steady_clock::time_point late_at, const std::function<void()>& update);

  std::chrono::milliseconds catchUp() const { return options_.catch_up; }

  /// Scans whose update was raised to `late_nice` (they were late).
  std::uint64_t promotions() const;

 private:
  void setNice(int nice);  // under mutex_
  void watch();

  UpdatePriorityOptions options_;
  std::vector<int> team_;  // thread ids of the caller and its OpenMP workers
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  int nice_ = 0;
  bool running_ = false;
  bool stopping_ = false;
  std::chrono::steady_clock::time_point late_at_{};
  std::uint64_t promotions_ = 0;
  std::thread watcher_;
};

}  // namespace densemap::server
