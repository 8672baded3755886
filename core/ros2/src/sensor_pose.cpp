#include "densemap/ros2/sensor_pose.h"

#include "densemap/ros2/message_codec.h"

namespace densemap::ros2 {

std::vector<std::string> addTfMessage(TfBuffer& buffer, std::span<const std::uint8_t> sample,
                                      bool is_static) {
  std::vector<std::string> refused;
  for (const TransformStamped& t : decodeTfMessage(sample).transforms)
    if (auto why = buffer.add(t, is_static)) refused.push_back(std::move(*why));
  return refused;
}

bool isPoseType(const std::string& type) { return type == kOdometryType || type == kPoseStampedType; }

std::optional<std::string> addPoseMessage(TfBuffer& buffer, const std::string& type,
                                          std::span<const std::uint8_t> sample,
                                          const std::string& base_frame) {
  if (!isPoseType(type))
    return "pose topic of type " + type + " (expected " + kOdometryType + " or " + kPoseStampedType + ")";
  const PoseStamped p = type == kOdometryType ? decodeOdometry(sample) : decodePoseStamped(sample);
  TransformStamped t;
  t.header = p.header;
  t.child_frame_id = p.child_frame_id.empty() ? base_frame : p.child_frame_id;
  t.translation = p.position;
  t.rotation = p.orientation;
  return buffer.add(t, false);
}

SensorPose sensorPoseOf(const Eigen::Isometry3d& t) {
  const Eigen::Quaterniond q(t.rotation());
  return {{t.translation().x(), t.translation().y(), t.translation().z()}, {q.w(), q.x(), q.y(), q.z()}};
}

}  // namespace densemap::ros2
