// io::SpinningLidarModel and the simulator's real-sensor render: the beam tables, one unit's
// calibration, lost returns, and what projecting such a scan on a uniform image grid does to it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "densemap/densify/densify_dataset.h"
#include "densemap/densify/range_image.h"
#include "densemap/io/lidar_simulator.h"
#include "densemap/io/spinning_lidar_model.h"

using namespace densemap;

TEST(SpinningLidarModel, Hdl64eHasTwoBlocksOfDifferentSpacing) {
  const auto m = io::SpinningLidarModel::hdl64e();
  ASSERT_EQ(m.beams(), 64);
  EXPECT_DOUBLE_EQ(m.elevation_deg.front(), 2.0);
  EXPECT_NEAR(m.elevation_deg.back(), -24.33, 1e-9);
  EXPECT_NEAR(m.elevation_deg[0] - m.elevation_deg[1], 1.0 / 3.0, 0.01);
  EXPECT_NEAR(m.elevation_deg[40] - m.elevation_deg[41], 0.5, 0.01);
  EXPECT_TRUE(std::is_sorted(m.elevation_deg.rbegin(), m.elevation_deg.rend()));
  EXPECT_EQ(io::SpinningLidarModel::vlp16().beams(), 16);
  EXPECT_EQ(io::SpinningLidarModel::os1_64().beams(), 64);
  EXPECT_THROW(io::SpinningLidarModel::byName("hdl32"), std::invalid_argument);
}

TEST(SpinningLidarModel, AUnitIsTheTableWithinItsCalibrationOffsetsAndRepeatsForItsSeed) {
  const auto m = io::SpinningLidarModel::hdl64e();
  const auto a = m.unit(5), b = m.unit(5), c = m.unit(6);
  EXPECT_EQ(a.elevation_deg, b.elevation_deg);
  EXPECT_NE(a.elevation_deg, c.elevation_deg);
  for (int i = 0; i < m.beams(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    EXPECT_LE(std::abs(a.elevation_deg[k] - m.elevation_deg[k]), 0.08);
    EXPECT_LE(std::abs(a.azimuth_offset_deg[k]), 0.3);
    EXPECT_LE(std::abs(a.height_offset_m[k]), 0.1);
  }
  EXPECT_LE(a.tilt_deg, 0.3);
}

TEST(SpinningLidarModel, CastHitGivesTheSurfaceNormalAndMarksFoliage) {
  io::SceneOptions o;
  o.hedges = 4;
  const io::ProceduralScene scene(o);
  const Eigen::Vector3d origin(0, 0, 1.73);
  const auto ground = scene.castHit(origin, Eigen::Vector3d(1, 0, -1).normalized(), 100);
  ASSERT_TRUE(ground);
  EXPECT_NEAR(ground->range, 1.73 * std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(ground->normal.z(), 1.0, 1e-12);
  EXPECT_FALSE(ground->vegetation);
  // A crown seen from beside its tree: the hit is foliage and its normal faces the ray.
  const auto& crown = scene.spheres().front();
  const Eigen::Vector3d from = crown.center - Eigen::Vector3d(crown.radius + 0.5, 0, 0);
  const auto hit = scene.castHit(from, Eigen::Vector3d::UnitX(), 100);
  ASSERT_TRUE(hit);
  EXPECT_TRUE(hit->vegetation);
  EXPECT_LT(hit->normal.dot(Eigen::Vector3d::UnitX()), 0.0);
  // cast() and castHit() agree, hedges included.
  for (double yaw = 0; yaw < 6.28; yaw += 0.05) {
    const Eigen::Vector3d d(std::cos(yaw), std::sin(yaw), -0.02);
    const auto t = scene.cast(origin, d.normalized(), 120);
    const auto h = scene.castHit(origin, d.normalized(), 120);
    ASSERT_EQ(t.has_value(), h.has_value());
    if (t) {
      EXPECT_DOUBLE_EQ(*t, h->range);
    }
  }
}

TEST(SpinningLidarModel, ProjectedHdl64eScanLeavesGapsInTheLowerRowsAsRealScansDo) {
  // The lower lasers are 1/2 degree apart and the KITTI grid's rows 0.43: some lower rows get no beam,
  // while a uniform 64-beam render fills every row. This is what ILN trained on uniform renders never saw.
  io::LidarSimulatorOptions o;
  o.scans = 1;
  const io::LidarSimulator sim(o);
  const densify::LidarGeometry grid{64, 1024, 2.0, -24.9, 360.0};
  auto model = io::SpinningLidarModel::hdl64e();
  model.drop_probability = 0;
  model.far_drop_at_max = 0;
  model.grazing_drop_below_deg = 0;
  const auto real = densify::project(sim.render(0, model).sensorPoints(), grid);
  const auto uniform = densify::project(sim.render(0, grid).sensorPoints(), grid);
  auto rowFill = [&](const densify::RangeImage& im, int row) {
    int n = 0;
    for (int j = 0; j < im.columns(); ++j) n += im.at(row, j) > 0 ? 1 : 0;
    return static_cast<double>(n) / im.columns();
  };
  int sparse_real = 0, sparse_uniform = 0;
  for (int row = 30; row < 60; ++row) {  // rows all looking at the ground near the car
    sparse_real += rowFill(real, row) < 0.2 ? 1 : 0;
    sparse_uniform += rowFill(uniform, row) < 0.2 ? 1 : 0;
  }
  EXPECT_EQ(sparse_uniform, 0);
  EXPECT_GE(sparse_real, 3);
}

TEST(SpinningLidarModel, LostReturnsThinTheScan) {
  io::LidarSimulatorOptions o;
  o.scans = 1;
  const io::LidarSimulator sim(o);
  auto ideal = io::SpinningLidarModel::hdl64e();
  ideal.drop_probability = 0;
  ideal.far_drop_at_max = 0;
  ideal.grazing_drop_below_deg = 0;
  ideal.vegetation_drop = 0;
  const auto all = sim.render(0, ideal).points.size();
  const auto kept = sim.render(0, io::SpinningLidarModel::hdl64e()).points.size();
  EXPECT_GT(all, 50000u);
  EXPECT_LT(kept, all * 0.98);
  EXPECT_GT(kept, all * 0.7);
}
