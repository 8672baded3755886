// Log-odds sensor model and clamping (Eq. 2.2 and the clamping policy of Sec. 2.2.1).
#pragma once

#include <cmath>
#include <string>

namespace densemap::map {

/// Probabilities of the inverse sensor model. Defaults are OctoMap's, so maps compare bit for bit.
struct OccupancyParams {
  double prob_hit = 0.7;            ///< P(occupied | endpoint in the cell)
  double prob_miss = 0.4;           ///< P(occupied | ray passes through the cell)
  double clamp_min = 0.1192;        ///< lower clamping bound: at or below it a cell is "fully free"
  double clamp_max = 0.971;         ///< upper clamping bound: at or above it a cell is "fully occupied"
  double occupied_threshold = 0.5;  ///< probability above which a cell reads as occupied

  /// OctoMap's logodds(): computed in double, stored as float.
  static float logOdds(double p) { return static_cast<float>(std::log(p / (1.0 - p))); }
  /// The inverse: P(occupied) of a log-odds value (computed in double, returned as float).
  static float probability(float log_odds) {
    return static_cast<float>(1.0 / (1.0 + std::exp(-static_cast<double>(log_odds))));
  }

  /// Empty when valid, else a message saying what is wrong.
  std::string validate() const {
    auto in01 = [](double p) { return p > 0.0 && p < 1.0; };
    if (!in01(prob_hit) || !in01(prob_miss) || !in01(clamp_min) || !in01(clamp_max))
      return "occupancy probabilities must lie strictly between 0 and 1";
    if (prob_hit <= 0.5) return "prob_hit must be above 0.5";
    if (prob_miss >= 0.5) return "prob_miss must be below 0.5";
    if (clamp_min >= clamp_max) return "clamp_min must be below clamp_max";
    return {};
  }
};

/// The float log-odds constants used in updates, derived once from OccupancyParams.
struct LogOdds {
  float hit;
  float miss;
  float min;
  float max;
  float occupied;
  explicit LogOdds(const OccupancyParams& p)
      : hit(OccupancyParams::logOdds(p.prob_hit)),
        miss(OccupancyParams::logOdds(p.prob_miss)),
        min(OccupancyParams::logOdds(p.clamp_min)),
        max(OccupancyParams::logOdds(p.clamp_max)),
        occupied(OccupancyParams::logOdds(p.occupied_threshold)) {}
};

}  // namespace densemap::map
