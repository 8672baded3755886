// Whether one program is measurably slower than another from timings taken in the same rounds. Comparing a
// method's median with the least of several methods' medians favours that least one: the minimum of noisy
// medians is biased low (with four equal methods, it is below each of them more often than not). A paired
// test has no such bias: in each round both ran minutes apart at most, and the sign test asks only how often
// the first was the slower one.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace densemap::eval {

/// P(X >= k) for X ~ Binomial(n, 1/2): the one-sided sign test's p-value for k "slower" rounds of n.
inline double signTestPValue(int k, int n) {
  if (n <= 0 || k <= 0) return 1.0;
  if (k > n) return 0.0;
  double p = 0.0, c = 1.0;  // c = C(n, i)
  for (int i = 0; i <= n; ++i) {
    if (i >= k) p += c;
    c = c * static_cast<double>(n - i) / static_cast<double>(i + 1);
  }
  return p / std::pow(2.0, n);
}

struct PairedTiming {
  int rounds = 0;             ///< pairs compared
  int slower_rounds = 0;      ///< rounds where the first took strictly longer
  double median_ratio = 0.0;  ///< median over rounds of first / second
  double p_value = 1.0;       ///< sign test: that the first is no slower than the second
  /// At the 5% level; needs at least 5 rounds (4 of 4 slower has p = 1/16).
  bool measurablySlower(double alpha = 0.05) const { return p_value < alpha; }
};

/// first[i] and second[i] are times of round i (pairs beyond the shorter vector are ignored).
inline PairedTiming comparePaired(const std::vector<double>& first, const std::vector<double>& second) {
  PairedTiming t;
  std::vector<double> ratios;
  for (std::size_t i = 0; i < std::min(first.size(), second.size()); ++i) {
    if (!(second[i] > 0.0) || !std::isfinite(first[i])) continue;
    ratios.push_back(first[i] / second[i]);
    t.slower_rounds += first[i] > second[i] ? 1 : 0;
  }
  t.rounds = static_cast<int>(ratios.size());
  if (ratios.empty()) return t;
  std::sort(ratios.begin(), ratios.end());
  const std::size_t n = ratios.size();
  t.median_ratio = n % 2 ? ratios[n / 2] : 0.5 * (ratios[n / 2 - 1] + ratios[n / 2]);
  t.p_value = signTestPValue(t.slower_rounds, t.rounds);
  return t;
}

}  // namespace densemap::eval
