#include "densemap/server/update_priority.h"

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

}  // namespace densemap::server
