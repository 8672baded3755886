// The x y z of a sensor_msgs/PointCloud2, whatever its layout: float32 or float64 coordinates at any
// offsets, other fields and padding between, organised (height > 1) or not, rows padded (row_step larger
// than width * point_step). What cannot be read is refused with the reason, never guessed.
#pragma once

#include <cstddef>
#include <vector>

#include "densemap/geometry/voxel_key.h"
#include "densemap/ros2/messages.h"

namespace densemap::ros2 {

struct CloudPoints {
  std::vector<geometry::Vec3f> points;  ///< in the cloud's frame, in row-major order
  /// Points left out because a coordinate was NaN or infinite (organised clouds mark missing returns so).
  std::size_t nonfinite_points = 0;
};

/// Throws DecodeError for a big-endian cloud, missing or non-float x/y/z, a field past point_step,
/// row_step below width * point_step, or data shorter than row_step * height.
CloudPoints cloudPoints(const PointCloud2& cloud);

/// A PointCloud2 of `points` as x y z float32 (point_step 12), unorganised and dense, for tests and for
/// the edge's occupied-cell output; `storage` receives the bytes `cloud.data` views.
PointCloud2 makeXyzCloud(const std::vector<geometry::Vec3f>& points, const Header& header,
                         std::vector<std::uint8_t>& storage);

}  // namespace densemap::ros2
