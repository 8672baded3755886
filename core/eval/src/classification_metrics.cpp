#include "densemap/eval/classification_metrics.h"

#include <algorithm>
#include <numeric>

namespace densemap::eval {

ClassificationScores score(const std::vector<std::optional<float>>& predictions,
                           const std::vector<bool>& labels, double threshold) {
  ClassificationScores s;
  const std::size_t n = std::min(predictions.size(), labels.size());
  std::vector<std::pair<double, bool>> items(n);
  std::size_t answered = 0, right_occ = 0, right_free = 0;
  double se = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double p = predictions[i].value_or(0.5f);
    answered += predictions[i].has_value();
    items[i] = {p, labels[i]};
    const double y = labels[i] ? 1.0 : 0.0;
    se += (p - y) * (p - y);
    if (labels[i]) {
      ++s.occupied;
      right_occ += predictions[i] && p > threshold;
    } else {
      ++s.free;
      right_free += predictions[i] && p < threshold;
    }
  }
  if (n == 0) return s;
  s.mse = se / static_cast<double>(n);
  s.coverage = static_cast<double>(answered) / static_cast<double>(n);
  s.acc_occupied = s.occupied ? static_cast<double>(right_occ) / static_cast<double>(s.occupied) : 0;
  s.acc_free = s.free ? static_cast<double>(right_free) / static_cast<double>(s.free) : 0;
  // ROC: lower the threshold through the distinct probabilities; AUC by trapezoids (ties form one step).
  std::sort(items.begin(), items.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  const double pos = static_cast<double>(s.occupied), neg = static_cast<double>(s.free);
  double tp = 0, fp = 0, prev_fpr = 0, prev_tpr = 0;
  s.roc.push_back({1.0 + 1e-9, 0, 0});
  for (std::size_t i = 0; i < n;) {
    const double t = items[i].first;
    for (; i < n && items[i].first == t; ++i) (items[i].second ? tp : fp) += 1;
    const double fpr = neg > 0 ? fp / neg : 0, tpr = pos > 0 ? tp / pos : 0;
    s.auc += (fpr - prev_fpr) * (tpr + prev_tpr) / 2;
    s.roc.push_back({t, fpr, tpr});
    prev_fpr = fpr;
    prev_tpr = tpr;
  }
  return s;
}

}  // namespace densemap::eval
