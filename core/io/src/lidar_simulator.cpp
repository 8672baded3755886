#include "densemap/io/lidar_simulator.h"

#include <cmath>
#include <numbers>
#include <random>
#include <sstream>
#include <stdexcept>

namespace densemap::io {

LidarSimulatorOptions LidarSimulatorOptions::parse(const std::string& spec) {
  LidarSimulatorOptions o;
  std::stringstream ss(spec);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (item.empty()) continue;
    const auto eq = item.find('=');
    if (eq == std::string::npos)
      throw std::invalid_argument("simulator option '" + item + "' is not key=value");
    const std::string key = item.substr(0, eq), value = item.substr(eq + 1);
    double v;
    try {
      std::size_t used = 0;
      v = std::stod(value, &used);
      if (used != value.size()) throw std::invalid_argument(value);
    } catch (const std::exception&) {
      throw std::invalid_argument("simulator option '" + key + "' needs a number, got '" + value + "'");
    }
    if (key == "scans")
      o.scans = static_cast<int>(v);
    else if (key == "beams")
      o.lidar.rows = static_cast<int>(v);
    else if (key == "columns")
      o.lidar.columns = static_cast<int>(v);
    else if (key == "fov_up")
      o.lidar.fov_up_deg = v;
    else if (key == "fov_down")
      o.lidar.fov_down_deg = v;
    else if (key == "fov_h")
      o.lidar.fov_horizontal_deg = v;
    else if (key == "speed")
      o.speed = v;
    else if (key == "range")
      o.max_range = v;
    else if (key == "noise")
      o.range_noise = v;
    else if (key == "seed")
      o.seed = static_cast<std::uint64_t>(v);
    else if (key == "scene_seed")
      o.scene.seed = static_cast<std::uint64_t>(v);
    else if (key == "yaw_rate")
      o.yaw_rate_deg = v;
    else
      throw std::invalid_argument(
          "unknown simulator option '" + key +
          "' (known: scans, beams, columns, fov_up, fov_down, fov_h, speed, range, noise, "
          "seed, scene_seed, yaw_rate)");
  }
  if (o.scans < 1 || o.lidar.rows < 1 || o.lidar.columns < 1 || o.max_range <= 0 || o.range_noise < 0)
    throw std::invalid_argument("simulator: scans, beams, columns and range must be positive, noise >= 0");
  return o;
}

LidarSimulator::LidarSimulator(const LidarSimulatorOptions& options)
    : options_(options), scene_(options.scene) {}

Eigen::Isometry3d LidarSimulator::pose(std::size_t i) const {
  const double rate = options_.yaw_rate_deg * std::numbers::pi / 180.0;
  Eigen::Vector3d p(options_.start_x, 0.0, options_.sensor_height);
  double heading = 0.0;
  for (std::size_t k = 0; k < i; ++k) {
    p.x() += options_.speed * std::cos(heading);
    p.y() += options_.speed * std::sin(heading);
    heading += rate;
  }
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  t.translation() = p;
  return t;
}

Scan LidarSimulator::render(std::size_t i, const LidarGeometry& g) const {
  Scan s;
  s.index = i;
  s.frame = PointFrame::kSensor;
  s.pose = pose(i);
  s.lidar = g;
  std::mt19937_64 rng(options_.seed * 1000003ULL + i);
  std::normal_distribution<double> noise(0.0, options_.range_noise > 0 ? options_.range_noise : 1.0);
  const double deg = std::numbers::pi / 180.0;
  const Eigen::Vector3d o = s.pose.translation();
  s.points.reserve(static_cast<std::size_t>(g.rows) * static_cast<std::size_t>(g.columns));
  for (int r = 0; r < g.rows; ++r) {
    const double el =
        (g.rows > 1 ? g.fov_up_deg - r * (g.fov_up_deg - g.fov_down_deg) / (g.rows - 1) : g.fov_up_deg) * deg;
    for (int c = 0; c < g.columns; ++c) {
      const double az = (g.fov_horizontal_deg / 2.0 - (c + 0.5) * g.fov_horizontal_deg / g.columns) * deg;
      const Eigen::Vector3d dir_s(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      const auto hit = scene_.cast(o, s.pose.linear() * dir_s, options_.max_range);
      if (!hit) continue;  // no return: missing in the range image
      double range = *hit;
      if (options_.range_noise > 0) range += noise(rng);
      if (range <= 0.0) continue;
      s.points.push_back((dir_s * range).cast<float>());
    }
  }
  return s;
}

Scan LidarSimulator::render(std::size_t i, const SpinningLidarModel& m) const {
  Scan s;
  s.index = i;
  s.frame = PointFrame::kSensor;
  s.pose = pose(i);
  std::mt19937_64 rng(options_.seed * 1000003ULL + i * 7919ULL + 17);
  std::normal_distribution<double> noise(0.0, m.range_noise_m > 0 ? m.range_noise_m : 1.0);
  std::uniform_real_distribution<double> chance(0.0, 1.0);
  const double deg = std::numbers::pi / 180.0;
  const Eigen::Matrix3d rot = s.pose.linear();
  s.points.reserve(static_cast<std::size_t>(m.beams()) * static_cast<std::size_t>(m.firings_per_revolution));
  for (int b = 0; b < m.beams(); ++b) {
    const auto bi = static_cast<std::size_t>(b);
    const double height = bi < m.height_offset_m.size() ? m.height_offset_m[bi] : 0.0;
    const double az_offset = bi < m.azimuth_offset_deg.size() ? m.azimuth_offset_deg[bi] : 0.0;
    const Eigen::Vector3d laser(0.0, 0.0, height);  // sensor frame
    const Eigen::Vector3d origin = s.pose * laser;
    for (int c = 0; c < m.firings_per_revolution; ++c) {
      const double az_deg = 180.0 - (c + 0.5) * 360.0 / m.firings_per_revolution + az_offset;
      const double el_deg = m.elevation_deg[bi] + m.tilt_deg * std::sin((az_deg - m.tilt_azimuth_deg) * deg);
      const double az = az_deg * deg, el = el_deg * deg;
      const Eigen::Vector3d dir_s(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      const Eigen::Vector3d dir_w = rot * dir_s;
      const auto hit = scene_.castHit(origin, dir_w, std::min(options_.max_range, m.max_range_m));
      if (!hit) continue;
      double lost = m.drop_probability;
      if (hit->range > m.far_drop_from_m)
        lost += m.far_drop_at_max * (hit->range - m.far_drop_from_m) /
                std::max(1e-9, m.max_range_m - m.far_drop_from_m);
      if (m.grazing_drop_below_deg > 0) {
        const double incidence = std::asin(std::min(1.0, std::abs(hit->normal.dot(dir_w)))) / deg;
        if (incidence < m.grazing_drop_below_deg) lost += 1.0 - incidence / m.grazing_drop_below_deg;
      }
      if (hit->vegetation) lost += m.vegetation_drop;
      if (chance(rng) < lost) continue;
      double range = hit->range;
      if (hit->vegetation) range += m.vegetation_depth_m * chance(rng);
      if (m.range_noise_m > 0) range += noise(rng);
      if (range <= 0.0) continue;
      // The point as the sensor reports it: from the laser's own origin, in the sensor frame.
      s.points.push_back((laser + dir_s * range).cast<float>());
    }
  }
  return s;
}

Scan LidarSimulator::read(std::size_t i) const {
  if (i >= size()) throw SourceError("simulator: scan " + std::to_string(i) + " out of range");
  return render(i, options_.lidar);
}

std::string LidarSimulator::describe() const {
  std::ostringstream os;
  os << "built-in LiDAR simulator (" << options_.scans << " scans, " << options_.lidar.rows << "x"
     << options_.lidar.columns << " beams, procedural street scene seed " << options_.scene.seed << ")";
  return os.str();
}

}  // namespace densemap::io
