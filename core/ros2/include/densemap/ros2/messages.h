// The ROS 2 messages densemap reads and writes, as plain structs (no ROS, no DDS), field for field as
// their published definitions (sensor_msgs, geometry_msgs, nav_msgs, tf2_msgs, octomap_msgs, std_msgs).
// The IDL of the same messages, for DDS, is idl/ros2/; tests check that both agree byte for byte.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace densemap::ros2 {

/// builtin_interfaces/msg/Time.
struct Time {
  std::int32_t sec = 0;
  std::uint32_t nanosec = 0;
  std::int64_t nanoseconds() const { return std::int64_t{sec} * 1'000'000'000 + nanosec; }
  static Time fromNanoseconds(std::int64_t ns);
};

/// std_msgs/msg/Header.
struct Header {
  Time stamp;
  std::string frame_id;
};

/// sensor_msgs/msg/PointField. Datatype codes as the message defines them.
struct PointField {
  enum Type : std::uint8_t {
    kInt8 = 1,
    kUint8 = 2,
    kInt16 = 3,
    kUint16 = 4,
    kInt32 = 5,
    kUint32 = 6,
    kFloat32 = 7,
    kFloat64 = 8
  };
  std::string name;
  std::uint32_t offset = 0;
  std::uint8_t datatype = 0;
  std::uint32_t count = 1;
};

/// sensor_msgs/msg/PointCloud2. `data` views the sample it was decoded from (or `owned_data`).
struct PointCloud2 {
  Header header;
  std::uint32_t height = 1;
  std::uint32_t width = 0;
  std::vector<PointField> fields;
  bool is_bigendian = false;
  std::uint32_t point_step = 0;
  std::uint32_t row_step = 0;
  std::span<const std::uint8_t> data;
  bool is_dense = true;
};

/// geometry_msgs Vector3 / Point and Quaternion (x, y, z, w as the message orders them).
using Vector3 = std::array<double, 3>;
struct Quaternion {
  double x = 0, y = 0, z = 0, w = 1;
};

/// geometry_msgs/msg/TransformStamped: header.frame_id (parent) <- child_frame_id.
struct TransformStamped {
  Header header;
  std::string child_frame_id;
  Vector3 translation{0, 0, 0};
  Quaternion rotation;
};

/// tf2_msgs/msg/TFMessage.
struct TfMessage {
  std::vector<TransformStamped> transforms;
};

/// geometry_msgs/msg/PoseStamped, or the pose of a nav_msgs/msg/Odometry (its child_frame_id is kept;
/// covariance and twist are read and dropped).
struct PoseStamped {
  Header header;
  std::string child_frame_id;  ///< empty for PoseStamped
  Vector3 position{0, 0, 0};
  Quaternion orientation;
};

/// nav_msgs/msg/MapMetaData + OccupancyGrid.
struct OccupancyGrid {
  Header header;
  Time map_load_time;
  float resolution = 0;
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  Vector3 origin_position{0, 0, 0};
  Quaternion origin_orientation;
  std::vector<std::int8_t> data;  ///< row-major from the origin; -1 unknown, 0 free, 100 occupied
};

/// octomap_msgs/msg/Octomap.
struct Octomap {
  Header header;
  bool binary = true;
  std::string id;  ///< "OcTree"
  double resolution = 0;
  std::vector<std::int8_t> data;
};

}  // namespace densemap::ros2
