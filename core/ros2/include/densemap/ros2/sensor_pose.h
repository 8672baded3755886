// Where a cloud was taken: its frame's pose in the fixed frame at its stamp, from TF (/tf, /tf_static) or
// from a pose topic (nav_msgs/Odometry or geometry_msgs/PoseStamped of the base frame). The live edge and
// the bag sources feed the same buffer the same way, so both give a cloud the same pose.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "densemap/ros2/tf_buffer.h"

namespace densemap::ros2 {

/// octomap_server's frame parameters and the topics clouds and poses come on.
struct FrameOptions {
  std::string cloud_topic;          ///< "" = a bag's only PointCloud2 topic; the edge's default is /cloud_in
  std::string fixed_frame = "map";  ///< octomap_server's frame_id: the map's frame
  std::string base_frame = "base_footprint";  ///< octomap_server's base_frame_id: a pose topic's child
  std::string pose_topic;                     ///< "" = TF; else an Odometry or PoseStamped topic
};

inline constexpr const char* kTfTopic = "/tf";
inline constexpr const char* kTfStaticTopic = "/tf_static";

/// Decodes a TFMessage and adds its transforms; returns one reason per transform refused.
/// Throws DecodeError when the sample cannot be read at all.
std::vector<std::string> addTfMessage(TfBuffer& buffer, std::span<const std::uint8_t> sample, bool is_static);

/// Decodes a pose message of `type` (Odometry or PoseStamped) and adds it as the stamped transform
/// header.frame_id <- child (Odometry's child_frame_id, else `base_frame`). Returns the reason when refused.
std::optional<std::string> addPoseMessage(TfBuffer& buffer, const std::string& type,
                                          std::span<const std::uint8_t> sample,
                                          const std::string& base_frame);

bool isPoseType(const std::string& type);

/// A looked-up transform as the position and quaternion (w, x, y, z) a scan carries. The edge sends
/// these through the service's scan check, which builds the pose with io::poseFromQuaternion; bag
/// sources build it the same way, so a bag mapped offline and the same bag served see identical poses.
struct SensorPose {
  std::array<double, 3> position{0, 0, 0};
  std::array<double, 4> wxyz{1, 0, 0, 0};
};
SensorPose sensorPoseOf(const Eigen::Isometry3d& fixed_from_sensor);

}  // namespace densemap::ros2
