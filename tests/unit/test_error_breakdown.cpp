// densify::ErrorBreakdown: an upsampler's range error split by where the pixel is.
#include <gtest/gtest.h>

#include <map>

#include "densemap/densify/densify_dataset.h"
#include "densemap/densify/error_breakdown.h"
#include "densemap/io/lidar_simulator.h"
#include "test_simulator.h"

using namespace densemap;
using densify::LidarGeometry;
using densify::RangeImage;

namespace {
std::map<std::string, densify::ErrorBin> byName(const densify::ErrorBreakdown& b) {
  std::map<std::string, densify::ErrorBin> out;
  for (const auto& bin : b.bins()) out[bin.name] = bin;
  return out;
}
}  // namespace

TEST(ErrorBreakdown, AnErrorOnOneRowLandsInItsBinsOnly) {
  io::LidarSimulator sim(test::smallSimulator(1, 64, 256));
  const LidarGeometry dense{64, 256, 2.0, -24.9, 360.0};
  const RangeImage target = densify::project(sim.render(0, dense).sensorPoints(), dense);
  const RangeImage input = densify::keepEveryNthRow(target, 4);
  RangeImage predicted = target;
  // Row 2 lies between input rows 0 and 4, and is one of the top 4 rows: 0.5 m too far everywhere.
  std::size_t changed = 0;
  for (int j = 0; j < dense.columns; ++j)
    if (predicted.at(2, j) > 0) {
      predicted.at(2, j) += 0.5f;
      ++changed;
    }
  ASSERT_GT(changed, 10u);
  densify::ErrorBreakdown breakdown;
  breakdown.add(input, predicted, target);
  const auto bins = byName(breakdown);
  EXPECT_DOUBLE_EQ(bins.at("on an input row").mae(), 0.0);
  EXPECT_GT(bins.at("on an input row").pixels, 1000u);
  const auto& between = bins.at("between input rows");
  EXPECT_NEAR(between.abs_error_sum, 0.5 * static_cast<double>(changed), 1e-3);
  EXPECT_NEAR(bins.at("top 4 rows").abs_error_sum, 0.5 * static_cast<double>(changed), 1e-3);
  EXPECT_DOUBLE_EQ(bins.at("bottom 4 rows").abs_error_sum, 0.0);
  // Every pixel both images have is counted once in each partition (row, range, edge, ground).
  const std::size_t all =
      bins.at("on an input row").pixels + between.pixels + bins.at("below the last input row").pixels;
  EXPECT_EQ(all, target.validCount());
  EXPECT_EQ(bins.at("range 0-10 m").pixels + bins.at("range 10-20 m").pixels +
                bins.at("range 20-40 m").pixels + bins.at("range 40 m and more").pixels,
            all);
  EXPECT_EQ(bins.at("at a depth edge").pixels + bins.at("smooth neighbourhood").pixels, all);
  EXPECT_EQ(bins.at("ground").pixels + bins.at("above the ground").pixels, all);
  // The simulated street has a ground plane 1.73 m below the sensor: much of the image is ground.
  EXPECT_GT(bins.at("ground").pixels, all / 10);
}

TEST(ErrorBreakdown, RefusesImagesOfDifferentSizes) {
  const LidarGeometry dense{64, 256, 2.0, -24.9, 360.0};
  RangeImage target(dense), other(LidarGeometry{32, 256, 2.0, -24.9, 360.0});
  densify::ErrorBreakdown breakdown;
  EXPECT_THROW(breakdown.add(densify::keepEveryNthRow(target, 4), other, target), std::invalid_argument);
}
