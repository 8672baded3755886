// One LiDAR scan: points, the sensor pose, and optionally the LiDAR geometry range-image stages need.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "densemap/geometry/voxel_key.h"

namespace densemap::io {

using geometry::Vec3f;

/// A spinning LiDAR's beam layout. Beam i (row 0 = top) points at elevation
/// fov_up - i * (fov_up - fov_down) / (rows - 1); column j at azimuth fov_h/2 - (j + 0.5) * fov_h / columns
/// (degrees, x forward, y left, z up; azimuth measured from +x toward +y).
struct LidarGeometry {
  int rows = 64;
  int columns = 1024;
  double fov_up_deg = 2.0;
  double fov_down_deg = -24.9;
  double fov_horizontal_deg = 360.0;
};

enum class PointFrame { kSensor, kWorld };

struct Scan {
  std::uint64_t index = 0;
  std::vector<Vec3f> points;
  PointFrame frame = PointFrame::kSensor;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  ///< world <- sensor
  std::optional<LidarGeometry> lidar;
  /// Points the reader left out because a coordinate was NaN/Inf (organised PCD clouds mark gaps so).
  std::size_t nonfinite_points = 0;

  Vec3f origin() const { return pose.translation().cast<float>(); }
  /// Points in the world frame (transformed in double, rounded to float once).
  std::vector<Vec3f> worldPoints() const;
  /// Points in the sensor frame.
  std::vector<Vec3f> sensorPoints() const;
};

/// The pose a position and a quaternion (w, x, y, z) describe, normalising the quaternion. The server builds
/// received poses with it, so offline references that use it too see bit-identical world points.
Eigen::Isometry3d poseFromQuaternion(const std::array<double, 3>& position,
                                     const std::array<double, 4>& wxyz);
/// The quaternion (w, x, y, z) of a pose's rotation.
std::array<double, 4> quaternionOf(const Eigen::Isometry3d& pose);

/// A file or data problem; the message names the file and what was wrong.
class SourceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace densemap::io
