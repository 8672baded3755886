// Where a range-image upsampler's error comes from (find where ILN loses before changing the
// simulator): the mean absolute range error over the pixels both images have, split by the pixel's row
// relative to the input beams, its true range, whether its input neighbours straddle a depth
// discontinuity, whether it lies on the ground, and whether it sits at the vertical field of view's edges.
#pragma once

#include <string>
#include <vector>

#include "densemap/densify/range_image.h"

namespace densemap::densify {

struct ErrorBin {
  std::string name;
  double abs_error_sum = 0;  ///< metres
  std::size_t pixels = 0;
  double mae() const { return pixels ? abs_error_sum / static_cast<double>(pixels) : 0.0; }
};

struct ErrorBreakdownOptions {
  int beam_step = 4;            ///< the input keeps every beam_step-th target row from the top
  double sensor_height = 1.73;  ///< ground is within ground_band of z = -sensor_height (sensor frame)
  double ground_band = 0.3;     ///< metres
  double discontinuity = 1.2;   ///< neighbours' largest / smallest range above this: a depth edge
};

/// Accumulates the error of predicted images against their targets, bin by bin, over many scans.
class ErrorBreakdown {
 public:
  explicit ErrorBreakdown(const ErrorBreakdownOptions& options = {});
  /// Adds one scan: `input` is the sparse image the prediction was made from (for the discontinuity test).
  void add(const RangeImage& input, const RangeImage& predicted, const RangeImage& target);
  const std::vector<ErrorBin>& bins() const { return bins_; }

 private:
  void count(std::size_t bin, double error);
  ErrorBreakdownOptions options_;
  std::vector<ErrorBin> bins_;
};

}  // namespace densemap::densify
