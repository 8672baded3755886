#include "densemap/server/update_priority.h"

#include <stdexcept>

#include <omp.h>
#include <pthread.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>

#include <spdlog/spdlog.h>

namespace densemap::server {

namespace {
int threadId() { return static_cast<int>(syscall(SYS_gettid)); }
bool setThreadNice(int tid, int nice) { return setpriority(PRIO_PROCESS, static_cast<id_t>(tid), nice) == 0; }
}  // namespace

std::vector<int> openmpTeamThreadIds() {
  std::vector<int> ids(static_cast<std::size_t>(omp_get_max_threads()), 0);
#pragma omp parallel
  ids[static_cast<std::size_t>(omp_get_thread_num())] = threadId();
  ids.erase(std::remove(ids.begin(), ids.end(), 0), ids.end());
  return ids;
}

bool setThreadsNice(const std::vector<int>& thread_ids, int nice) {
  bool ok = true;
  for (int tid : thread_ids) ok = setThreadNice(tid, nice) && ok;
  return ok;
}

bool UpdatePriority::canRaisePriority(int to) {
  // Try it on a throw-away thread: lower it, then raise it to `to`.
  bool ok = false;
  std::thread probe([&] { ok = setThreadNice(threadId(), 1) && setThreadNice(threadId(), to); });
  probe.join();
  return ok;
}

UpdatePriority::UpdatePriority(UpdatePriorityOptions options) : options_(options) {
  if (options_.low_nice > 0) watcher_ = std::thread([this] { watch(); });
}

UpdatePriority::~UpdatePriority() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  if (watcher_.joinable()) watcher_.join();
}

void UpdatePriority::setNice(int nice) {
  if (nice == nice_) return;
  setThreadsNice(team_, nice);
  nice_ = nice;
}

void UpdatePriority::run(std::chrono::steady_clock::time_point late_at, const std::function<void()>& update) {
  if (options_.low_nice <= 0) {
    update();
    return;
  }
  {
    std::lock_guard lock(mutex_);
    if (team_.empty()) {
      team_ = openmpTeamThreadIds();
      nice_ = 0;
    }
    setNice(std::chrono::steady_clock::now() < late_at ? options_.low_nice : options_.late_nice);
    if (nice_ == options_.late_nice) ++promotions_;  // late before it started
    running_ = true;
    late_at_ = late_at;
  }
  changed_.notify_all();
  update();
  {
    std::lock_guard lock(mutex_);
    running_ = false;
    // Back to the low priority between scans: libgomp's workers spin for a while after a parallel region,
    // and at a late scan's priority that spinning would take the cores from queries.
    setNice(options_.low_nice);
  }
}

void UpdatePriority::watch() {
  pthread_setname_np(pthread_self(), "dm-update-prio");
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    if (!running_ || nice_ == options_.late_nice) {
      changed_.wait(lock);
      continue;
    }
    // A scan is being updated at the low priority: raise it when it becomes late.
    if (changed_.wait_until(lock, late_at_) == std::cv_status::timeout && running_ &&
        nice_ != options_.late_nice && std::chrono::steady_clock::now() >= late_at_) {
      setNice(options_.late_nice);
      ++promotions_;
      spdlog::debug("map update raised to nice {}: the scan is late", options_.late_nice);
    }
  }
}

std::uint64_t UpdatePriority::promotions() const {
  std::lock_guard lock(mutex_);
  return promotions_;
}

UpdatePriorityOptions resolveUpdatePriority(int update_nice, int catch_up_ms, int late_nice) {
  UpdatePriorityOptions p;
  p.catch_up = std::chrono::milliseconds(catch_up_ms);
  const bool can_raise = UpdatePriority::canRaisePriority();
  p.low_nice = update_nice >= 0 ? update_nice : can_raise ? 19 : 0;
  if (late_nice < 0) {
    if (p.low_nice == 0) {
      spdlog::warn(
          "--update-late-nice {} has no effect: the update always runs at normal priority (--update-nice "
          "0, or -1 without the right to raise priorities back)",
          late_nice);
    } else if (!UpdatePriority::canRaisePriority(late_nice)) {
      spdlog::warn(
          "late scans updated at nice 0, not {}: this process may not go below 0 (root, CAP_SYS_NICE "
          "or `ulimit -e {}`)",
          late_nice, 20 - late_nice);
    } else {
      p.late_nice = late_nice;
    }
  }
  if (p.low_nice > 0 && can_raise) {
    spdlog::info("map update at nice {} while scans are on time, nice {} once one is {} ms late", p.low_nice,
                 p.late_nice, catch_up_ms);
  } else if (p.low_nice > 0) {
    spdlog::warn(
        "map update at nice {}; this process may not raise it back when scans are late (no "
        "CAP_SYS_NICE, RLIMIT_NICE < 20), so a heavy query load can delay the map",
        p.low_nice);
  } else if (update_nice < 0) {
    spdlog::info(
        "map update at normal priority: to let queries go first, allow raising priorities back "
        "(`ulimit -e 20`, CAP_SYS_NICE or root)");
  }
  return p;
}

}  // namespace densemap::server
