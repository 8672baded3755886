// ROS 2 CDR bytes <-> the structs of messages.h: the one codec densemap has for ROS 2 samples, used for
// bags and for the live DDS edge alike, so an offline map of a bag and the served map read the same bytes
// the same way. Decoders throw DecodeError naming the field; they never allocate what the sample does not
// hold.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "densemap/ros2/cdr.h"
#include "densemap/ros2/messages.h"

namespace densemap::ros2 {

/// ROS 2 type names ("pkg/msg/Type") and their DDS names ("pkg::msg::dds_::Type_"), as rmw_fastrtps forms
/// them.
inline constexpr const char* kPointCloud2Type = "sensor_msgs/msg/PointCloud2";
inline constexpr const char* kTfMessageType = "tf2_msgs/msg/TFMessage";
inline constexpr const char* kPoseStampedType = "geometry_msgs/msg/PoseStamped";
inline constexpr const char* kOdometryType = "nav_msgs/msg/Odometry";
inline constexpr const char* kOccupancyGridType = "nav_msgs/msg/OccupancyGrid";
inline constexpr const char* kOctomapType = "octomap_msgs/msg/Octomap";

PointCloud2 decodePointCloud2(std::span<const std::uint8_t> sample);
TfMessage decodeTfMessage(std::span<const std::uint8_t> sample);
PoseStamped decodePoseStamped(std::span<const std::uint8_t> sample);
/// nav_msgs/msg/Odometry's header, child frame and pose.
PoseStamped decodeOdometry(std::span<const std::uint8_t> sample);
Octomap decodeOctomap(std::span<const std::uint8_t> sample);
OccupancyGrid decodeOccupancyGrid(std::span<const std::uint8_t> sample);

std::vector<std::uint8_t> encode(const PointCloud2& cloud);
std::vector<std::uint8_t> encode(const TfMessage& message);
std::vector<std::uint8_t> encodePoseStamped(const PoseStamped& pose);
std::vector<std::uint8_t> encodeOdometry(const PoseStamped& pose);
std::vector<std::uint8_t> encode(const OccupancyGrid& grid);
std::vector<std::uint8_t> encode(const Octomap& map);

/// Services (octomap_msgs/srv/BoundingBoxQuery, GetOctomap, std_srvs/srv/Empty). An empty ROS 2 message
/// carries one uint8 (rosidl's structure_needs_at_least_one_member).
struct BoundingBox {
  Vector3 min{0, 0, 0};
  Vector3 max{0, 0, 0};
};
BoundingBox decodeBoundingBoxRequest(std::span<const std::uint8_t> sample);
std::vector<std::uint8_t> encodeBoundingBoxRequest(const BoundingBox& box);
void decodeEmpty(std::span<const std::uint8_t> sample);
std::vector<std::uint8_t> encodeEmpty();
/// GetOctomap's response is one Octomap.
inline std::vector<std::uint8_t> encodeGetOctomapResponse(const Octomap& map) { return encode(map); }

}  // namespace densemap::ros2
