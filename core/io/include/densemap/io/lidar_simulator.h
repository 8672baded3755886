// The built-in LiDAR simulator: a spinning LiDAR driven along the road of a ProceduralScene. It is the
// demo's default source, feeds tests, and renders the same scene at several beam resolutions.
#pragma once

#include <string>

#include "densemap/io/procedural_scene.h"
#include "densemap/io/scan_source.h"
#include "densemap/io/spinning_lidar_model.h"

namespace densemap::io {

struct LidarSimulatorOptions {
  LidarGeometry lidar{};        ///< beams, columns, fields of view (KITTI HDL-64E-like by default)
  int scans = 20;               ///< number of scans along the trajectory
  double speed = 1.0;           ///< metres travelled between scans (10 m/s at 10 Hz)
  double start_x = -10.0;       ///< x of the first pose (m)
  double sensor_height = 1.73;  ///< z of the sensor (m), as on the KITTI car
  double max_range = 80.0;      ///< returns beyond this are missing (m)
  double range_noise = 0.0;     ///< standard deviation of Gaussian range noise (m)
  double yaw_rate_deg = 0.0;    ///< heading change per scan (degrees)
  std::uint64_t seed = 1;       ///< noise seed (the scene has its own seed in `scene`)
  SceneOptions scene{};

  /// Parses "key=value,..." (keys: scans, beams, columns, fov_up, fov_down, fov_h, speed, range, noise,
  /// seed, scene_seed, yaw_rate); throws std::invalid_argument naming an unknown key or bad value.
  static LidarSimulatorOptions parse(const std::string& spec);
};

class LidarSimulator : public ScanSource {
 public:
  explicit LidarSimulator(const LidarSimulatorOptions& options = {});
  std::size_t size() const override { return static_cast<std::size_t>(options_.scans); }
  Scan read(std::size_t i) const override;
  std::string describe() const override;

  /// Renders scan i's pose with another beam layout (e.g. 16 and 64 beams of the same scene).
  Scan render(std::size_t i, const LidarGeometry& lidar) const;
  /// Renders scan i's pose as a real sensor sees it (its beam table, offsets, tilt, noise and lost
  /// returns); the points are in the sensor frame and carry no pixel grid: project them as real scans.
  Scan render(std::size_t i, const SpinningLidarModel& sensor) const;
  Eigen::Isometry3d pose(std::size_t i) const;
  const ProceduralScene& scene() const { return scene_; }
  const LidarSimulatorOptions& options() const { return options_; }

 private:
  LidarSimulatorOptions options_;
  ProceduralScene scene_;
};

}  // namespace densemap::io
