#include "densemap/io/spinning_lidar_model.h"

#include <random>
#include <stdexcept>

namespace densemap::io {

namespace {
std::vector<double> evenly(double top, double bottom, int n) {
  std::vector<double> out;
  for (int i = 0; i < n; ++i) out.push_back(n > 1 ? top + (bottom - top) * i / (n - 1) : top);
  return out;
}
}  // namespace

SpinningLidarModel SpinningLidarModel::hdl64e() {
  SpinningLidarModel m;
  m.name = "hdl64e";
  m.elevation_deg = evenly(2.0, -8.33, 32);
  const auto lower = evenly(-8.83, -24.33, 32);
  m.elevation_deg.insert(m.elevation_deg.end(), lower.begin(), lower.end());
  m.firings_per_revolution = 2000;
  m.range_noise_m = 0.02;
  m.drop_probability = 0.03;
  m.far_drop_from_m = 40.0;
  m.far_drop_at_max = 0.6;
  m.grazing_drop_below_deg = 3.0;
  m.vegetation_drop = 0.3;
  m.vegetation_depth_m = 0.4;
  m.max_range_m = 120.0;
  return m;
}

SpinningLidarModel SpinningLidarModel::vlp16() {
  SpinningLidarModel m;
  m.name = "vlp16";
  m.elevation_deg = evenly(15.0, -15.0, 16);
  m.firings_per_revolution = 1800;
  m.range_noise_m = 0.03;
  m.drop_probability = 0.02;
  m.far_drop_from_m = 50.0;
  m.far_drop_at_max = 0.5;
  m.grazing_drop_below_deg = 3.0;
  m.max_range_m = 100.0;
  return m;
}

SpinningLidarModel SpinningLidarModel::os1_64() {
  SpinningLidarModel m;
  m.name = "os1_64";
  m.elevation_deg = evenly(22.5, -22.5, 64);
  m.firings_per_revolution = 2048;
  m.range_noise_m = 0.03;
  m.drop_probability = 0.02;
  m.far_drop_from_m = 40.0;
  m.far_drop_at_max = 0.6;
  m.grazing_drop_below_deg = 3.0;
  m.max_range_m = 120.0;
  return m;
}

SpinningLidarModel SpinningLidarModel::byName(const std::string& name) {
  if (name == "hdl64e") return hdl64e();
  if (name == "vlp16") return vlp16();
  if (name == "os1_64") return os1_64();
  throw std::invalid_argument("unknown LiDAR model '" + name + "' (known: hdl64e, vlp16, os1_64)");
}

SpinningLidarModel SpinningLidarModel::unit(std::uint64_t seed, double elevation_jitter_deg,
                                            double azimuth_jitter_deg, double height_jitter_m,
                                            double tilt_deg_max) const {
  SpinningLidarModel u = *this;
  std::mt19937_64 rng(seed);
  auto uni = [&](double a) { return std::uniform_real_distribution<double>(-a, a)(rng); };
  u.azimuth_offset_deg.assign(elevation_deg.size(), 0.0);
  u.height_offset_m.assign(elevation_deg.size(), 0.0);
  for (std::size_t b = 0; b < elevation_deg.size(); ++b) {
    u.elevation_deg[b] += uni(elevation_jitter_deg);
    u.azimuth_offset_deg[b] = uni(azimuth_jitter_deg);
    u.height_offset_m[b] = uni(height_jitter_m);
  }
  u.tilt_deg = std::abs(uni(tilt_deg_max));
  u.tilt_azimuth_deg = uni(180.0);
  return u;
}

}  // namespace densemap::io
