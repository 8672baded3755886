// At most one log line per interval from a place that a flood can reach (refused clients, refused
// participants): the count is kept elsewhere; the log only samples it. Safe from any thread.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <limits>

namespace densemap::util {

class LogThrottle {
 public:
  explicit LogThrottle(std::chrono::nanoseconds interval = std::chrono::seconds(1))
      : interval_(interval.count()) {}
  /// True when the last call that returned true was at least one interval ago.
  bool due() {
    const std::int64_t now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                                 std::chrono::steady_clock::now().time_since_epoch())
                                 .count();
    std::int64_t last = last_.load();
    while (now - last >= interval_) {
      if (last_.compare_exchange_weak(last, now)) return true;
    }
    return false;
  }

 private:
  const std::int64_t interval_;
  std::atomic<std::int64_t> last_{std::numeric_limits<std::int64_t>::min() / 2};
};

}  // namespace densemap::util
