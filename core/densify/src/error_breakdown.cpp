#include "densemap/densify/error_breakdown.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "densemap/densify/range_upsampler.h"

namespace densemap::densify {

namespace {
// Bin order; the names are what `densemap-iln eval --breakdown` prints.
enum Bin : std::size_t {
  kOnInputRow,
  kBetweenRows,
  kBelowLastInputRow,
  kRange0To10,
  kRange10To20,
  kRange20To40,
  kRange40Up,
  kDepthEdge,
  kSmooth,
  kGround,
  kAboveGround,
  kTopRows,
  kBottomRows,
  kBinCount
};
const char* const kNames[kBinCount] = {"on an input row",
                                       "between input rows",
                                       "below the last input row",
                                       "range 0-10 m",
                                       "range 10-20 m",
                                       "range 20-40 m",
                                       "range 40 m and more",
                                       "at a depth edge",
                                       "smooth neighbourhood",
                                       "ground",
                                       "above the ground",
                                       "top 4 rows",
                                       "bottom 4 rows"};
}  // namespace

ErrorBreakdown::ErrorBreakdown(const ErrorBreakdownOptions& options) : options_(options) {
  if (options_.beam_step < 1) throw std::invalid_argument("error breakdown: beam_step must be >= 1");
  for (const char* name : kNames) bins_.push_back(ErrorBin{name});
}

void ErrorBreakdown::count(std::size_t bin, double error) {
  bins_[bin].abs_error_sum += error;
  ++bins_[bin].pixels;
}

void ErrorBreakdown::add(const RangeImage& input, const RangeImage& predicted, const RangeImage& target) {
  if (predicted.range.size() != target.range.size())
    throw std::invalid_argument("error breakdown: predicted and target images differ in size");
  const LidarGeometry& g = target.geometry;
  const auto queries = queryNeighbours(input.geometry, g);
  const int last_input_row = ((input.rows() - 1) * options_.beam_step);
  for (int i = 0; i < g.rows; ++i) {
    for (int j = 0; j < g.columns; ++j) {
      const std::size_t k =
          static_cast<std::size_t>(i) * static_cast<std::size_t>(g.columns) + static_cast<std::size_t>(j);
      const float p = predicted.range[k], t = target.range[k];
      if (!(p > 0.0f) || !(t > 0.0f)) continue;
      const double e = std::abs(static_cast<double>(p) - t);
      count(i > last_input_row            ? kBelowLastInputRow
            : i % options_.beam_step == 0 ? kOnInputRow
                                          : kBetweenRows,
            e);
      count(t < 10 ? kRange0To10 : t < 20 ? kRange10To20 : t < 40 ? kRange20To40 : kRange40Up, e);
      // Neighbours: the 4 input pixels the query falls between; a missing one counts as an edge too.
      float lo = 1e30f, hi = 0.0f;
      for (const int n : queries[k].index) {
        const float r = input.range[static_cast<std::size_t>(n)];
        lo = std::min(lo, r);
        hi = std::max(hi, r);
      }
      count(!(lo > 0.0f) || hi / lo > options_.discontinuity ? kDepthEdge : kSmooth, e);
      double el = 0, az = 0;
      directionOf(g, i, j, el, az);
      const double z = t * std::sin(el * 3.14159265358979323846 / 180.0);
      count(std::abs(z + options_.sensor_height) <= options_.ground_band ? kGround : kAboveGround, e);
      if (i < 4) count(kTopRows, e);
      if (i >= g.rows - 4) count(kBottomRows, e);
    }
  }
}

}  // namespace densemap::densify
