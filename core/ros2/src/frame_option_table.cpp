#include "densemap/ros2/frame_option_table.h"

namespace densemap::ros2 {

void addFrameOptions(options::OptionTable& t, FrameOptions& f) {
  t.add("cloud-topic", f.cloud_topic,
        "ROS 2 sensor_msgs/PointCloud2 topic (bags: default their only one; the server's ROS 2 edge: "
        "/cloud_in)");
  t.add("frame-id", f.fixed_frame, "ROS 2 fixed frame the map is built in (octomap_server's frame_id)");
  t.add("base-frame-id", f.base_frame,
        "ROS 2 robot base frame: the child of a PoseStamped pose topic (octomap_server's base_frame_id)");
  t.add("pose-topic", f.pose_topic,
        "ROS 2 nav_msgs/Odometry or geometry_msgs/PoseStamped topic giving the base pose (default: use /tf)");
}

}  // namespace densemap::ros2
