#include "densemap/server/ros2_edge/ros2_options.h"

#include "densemap/ros2/frame_option_table.h"

namespace densemap::server::ros2_edge {

options::OptionTable ros2Options(Ros2EdgeOptions& o) {
  options::OptionTable t("ROS 2 edge (octomap_server's topics, services and parameters; docs/ROS2.md)");
  t.add("ros2", o.enabled, "also serve ROS 2 nodes: PointCloud2 + TF in, octomap_msgs and a 2D map out");
  t.add("ros2-only", o.only, "serve ROS 2 nodes only (no densemap topics)");
  t.add("node-name", o.node_name,
        "the ROS 2 node name: ~/clear_bbox and ~/reset are under it (octomap_server's)");
  t.add("ros2-security-dir", o.security_dir,
        "SROS2 enclave for the ROS 2 participant (e.g. KEYSTORE/enclaves/octomap_server from `ros2 security "
        "create_enclave`); empty: --security-dir")
      .exampleOnly();
  ros2::addFrameOptions(t, o.frames);
  t.add("pose-type", o.pose_type, "type of --pose-topic").oneOf({"odometry", "pose_stamped"});
  t.add("tf-timeout", o.tf_timeout_s,
        "seconds a cloud waits for its transform before it is dropped (counted)")
      .range(0.0, 60.0);
  t.add("tf-queue", o.tf_queue, "clouds waiting for transforms at most; a further one pushes out the oldest")
      .range(1, 1000);
  t.add("latch", o.latch, "map topics transient local, so late subscribers get the last map (Nav2 needs it)");
  t.add("map-publish-period", o.map_publish_period_s,
        "seconds between map publications when the map changed (0: as soon as it changed)")
      .range(0.0, 3600.0);
  t.add("occupancy-min-z", o.occupancy_min_z, "lowest cell centre height projected into projected_map (m)")
      .range(-1e6, 1e6);
  t.add("occupancy-max-z", o.occupancy_max_z, "highest cell centre height projected into projected_map (m)")
      .range(-1e6, 1e6);
  t.add("pointcloud-min-z", o.pointcloud_min_z,
        "points below this height in the fixed frame are not inserted (m)")
      .range(-1e6, 1e6);
  t.add("pointcloud-max-z", o.pointcloud_max_z,
        "points above this height in the fixed frame are not inserted (m)")
      .range(-1e6, 1e6);
  t.add("ros2-distribution", o.ros_distribution,
        "the ROS 2 distribution whose ros_discovery_info layout to publish, so `ros2 node list` shows the "
        "node (its Gid is 24 bytes in Humble and Iron, 16 in Jazzy)")
      .oneOf({"humble", "jazzy"});
  t.add("params-file", o.params_file,
        "octomap_server parameters YAML (ros__parameters): its values replace these defaults, flags win")
      .exampleOnly();
  return t;
}

}  // namespace densemap::server::ros2_edge
