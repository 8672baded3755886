// A densemap scan as a ROS 2 robot would publish it: its points as a PointCloud2 in the sensor frame and
// its pose as a TF transform fixed <- sensor at the same stamp. The simulator speaks ROS 2 through it
// (densemap-replay --ros2 without a bag), and tests record bags with it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "densemap/io/scan.h"

namespace densemap::ros2 {

struct ScanMessages {
  std::vector<std::uint8_t> cloud;      ///< sensor_msgs/PointCloud2 CDR
  std::vector<std::uint8_t> transform;  ///< tf2_msgs/TFMessage CDR
};

/// `sensor_frame` and `fixed_frame` name the frames; points are written x y z float32 + padding
/// (point_step 16, as Velodyne drivers send them).
ScanMessages scanMessages(const io::Scan& scan, std::int64_t stamp_ns, const std::string& fixed_frame,
                          const std::string& sensor_frame);

}  // namespace densemap::ros2
