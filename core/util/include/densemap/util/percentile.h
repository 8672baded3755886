// Nearest-rank percentiles: the one rule behind every latency figure (statistics, replay, benchmarks).
#pragma once

#include <algorithm>
#include <vector>

namespace densemap::util {

/// The value at rank floor(q * n) of `sorted` (ascending, not empty), q in [0, 1].
inline double percentileOfSorted(const std::vector<double>& sorted, double q) {
  return sorted[std::min(sorted.size() - 1,
                         static_cast<std::size_t>(q * static_cast<double>(sorted.size())))];
}

/// The same for unsorted values; 0 when there are none.
inline double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return percentileOfSorted(values, q);
}

}  // namespace densemap::util
