// A real spinning LiDAR's beam layout and its imperfections, for the simulator: the real
// sensor's elevation table (not a uniform spread), each unit's calibration offsets, a head that is not
// quite level, range noise and returns that never come back. ILN trained on clean uniform renders meets
// none of these on real scans (Sec. 4.4.5 trains on CARLA, whose LiDAR is uniform, too).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace densemap::io {

struct SpinningLidarModel {
  std::string name;
  std::vector<double> elevation_deg;       ///< per beam, from the top beam down
  std::vector<double> azimuth_offset_deg;  ///< per beam (empty: none)
  std::vector<double> height_offset_m;     ///< per beam: where its laser sits above the sensor origin
  int firings_per_revolution = 2048;       ///< returns per beam and turn
  double tilt_deg = 0.0;                   ///< the head's tilt: a beam's elevation swings by this over a turn
  double tilt_azimuth_deg = 0.0;
  double range_noise_m = 0.0;           ///< standard deviation of Gaussian range noise
  double drop_probability = 0.0;        ///< any return lost (dark or shiny surfaces)
  double far_drop_from_m = 1e9;         ///< beyond this the loss grows linearly ...
  double far_drop_at_max = 0.0;         ///< ... to this probability at max_range_m
  double grazing_drop_below_deg = 0.0;  ///< returns hitting a surface flatter than this angle are lost
                                        ///< with probability growing to 1 at 0 degrees
  double vegetation_drop = 0.0;         ///< extra loss on foliage (crowns, hedges) ...
  double vegetation_depth_m = 0.0;      ///< ... and how deep inside it a return may come from (uniform)
  double max_range_m = 120.0;

  int beams() const { return static_cast<int>(elevation_deg.size()); }

  /// Velodyne HDL-64E (KITTI): 32 upper lasers from +2.0 to -8.33 degrees (1/3 degree apart) and 32 lower
  /// ones from -8.83 to -24.33 degrees (1/2 degree apart), 120 m, 2 cm noise, about 2,000 returns per turn.
  static SpinningLidarModel hdl64e();
  /// Velodyne VLP-16: 16 beams from -15 to +15 degrees, 2 degrees apart, 100 m, 1,800 returns per turn.
  static SpinningLidarModel vlp16();
  /// Ouster OS1-64: 64 beams from -22.5 to +22.5 degrees (uniform), 2,048 returns per turn.
  static SpinningLidarModel os1_64();
  /// The preset by name (hdl64e, vlp16, os1_64); throws std::invalid_argument naming the known ones.
  static SpinningLidarModel byName(const std::string& name);

  /// One unit of this model: each beam's elevation, azimuth and height off the table by up to the given
  /// amounts (uniform), and a head tilted by up to `tilt_deg` in a random direction, all from `seed`.
  SpinningLidarModel unit(std::uint64_t seed, double elevation_jitter_deg = 0.08,
                          double azimuth_jitter_deg = 0.3, double height_jitter_m = 0.1,
                          double tilt_deg_max = 0.3) const;
};

}  // namespace densemap::io
