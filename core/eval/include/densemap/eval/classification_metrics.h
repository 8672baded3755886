// Scores of occupancy predictions on labelled test points: ROC curve and AUC, MSE of probabilities,
// accuracy on occupied and free points at a threshold, and coverage. A test point without an answer
// (unknown) scores as probability 0.5, and counts as wrong for the accuracies.
#pragma once

#include <optional>
#include <vector>

namespace densemap::eval {

struct RocPoint {
  double threshold, fpr, tpr;
};

struct ClassificationScores {
  double auc = 0, mse = 0, acc_occupied = 0, acc_free = 0, coverage = 0;
  std::size_t occupied = 0, free = 0;
  std::vector<RocPoint> roc;  ///< from (0,0) to (1,1), one point per distinct probability
};

/// `predictions[i]` is the probability for a test point labelled `labels[i]` (true: occupied), or nullopt.
ClassificationScores score(const std::vector<std::optional<float>>& predictions,
                           const std::vector<bool>& labels, double threshold = 0.5);

}  // namespace densemap::eval
