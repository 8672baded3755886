// ROS 2 names as rmw_fastrtps puts them on DDS: topics "rt/<name>", services "rq/<name>Request" and
// "rr/<name>Reply", types "<pkg>::msg::dds_::<Type>_" (and "<pkg>::srv::dds_::<Type>_Request_"). Names are
// resolved as rcl resolves them: relative to the namespace, "~" to the node's own name.
#pragma once

#include <string>

namespace densemap::ros2 {

/// "/cloud_in", "cloud_in" (namespace "/") or "~/clear_bbox" (node "octomap_server") -> the fully
/// qualified name; throws std::invalid_argument for a name ROS 2 would refuse.
std::string resolveName(const std::string& name, const std::string& node_name,
                        const std::string& node_namespace = "/");
/// "/cloud_in" -> "rt/cloud_in".
std::string topicOnDds(const std::string& resolved_topic);
/// "/octomap_server/clear_bbox" -> "rq/octomap_server/clear_bboxRequest" / "rr/...Reply".
std::string requestTopicOnDds(const std::string& resolved_service);
std::string replyTopicOnDds(const std::string& resolved_service);
/// "sensor_msgs/msg/PointCloud2" -> "sensor_msgs::msg::dds_::PointCloud2_".
std::string typeOnDds(const std::string& ros_type);
/// "std_srvs/srv/Empty" -> "std_srvs::srv::dds_::Empty_Request_" / "..._Response_".
std::string requestTypeOnDds(const std::string& service_type);
std::string responseTypeOnDds(const std::string& service_type);

}  // namespace densemap::ros2
