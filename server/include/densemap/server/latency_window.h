// The most recent latencies of a kind, for percentiles in the statistics (a fixed window, so memory stays
// bounded however long the server runs).
#pragma once

#include <algorithm>
#include <cstddef>
#include <mutex>
#include <vector>

#include "densemap/util/percentile.h"

namespace densemap::server {

struct LatencySummary {
  double p50_ms = 0.0;
  double p99_ms = 0.0;
  double max_ms = 0.0;
  std::size_t count = 0;  ///< samples in the window
};

class LatencyWindow {
 public:
  explicit LatencyWindow(std::size_t size = 2048) : samples_(size) {}

  void add(double ms) {
    std::lock_guard lock(mutex_);
    samples_[next_ % samples_.size()] = ms;
    ++next_;
  }

  LatencySummary summary() const {
    std::vector<double> v;
    {
      std::lock_guard lock(mutex_);
      v.assign(samples_.begin(),
               samples_.begin() + static_cast<std::ptrdiff_t>(std::min(next_, samples_.size())));
    }
    LatencySummary s;
    s.count = v.size();
    if (v.empty()) return s;
    std::sort(v.begin(), v.end());
    s.p50_ms = util::percentileOfSorted(v, 0.50);
    s.p99_ms = util::percentileOfSorted(v, 0.99);
    s.max_ms = v.back();
    return s;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<double> samples_;
  std::size_t next_ = 0;
};

}  // namespace densemap::server
