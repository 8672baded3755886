// densemap's ROS 2 edge: speaks to ROS 2 nodes over plain DDS as rmw_fastrtps does (docs/ROS2.md), with no
// ROS installation. In: sensor_msgs/PointCloud2 on the cloud topic, placed through /tf and /tf_static (or
// a pose topic). Out: octomap_msgs/Octomap (octomap_binary, octomap_full), nav_msgs/OccupancyGrid
// (projected_map) and the occupied centres (octomap_point_cloud_centers). Services: ~/clear_bbox,
// ~/reset, octomap_binary, octomap_full, in rmw_fastrtps' and rmw_cyclonedds' framing alike (told apart
// by the requester's DDS vendor, ros2/service_framing.h). The node is announced on ros_discovery_info, so
// ROS 2's tools list it. Names and parameters are octomap_server's, so it is a drop-in.
// Its threads: DDS's own (TF is added there), cloud intake (waits for TF like tf2's message filter),
// map publishing, services.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "densemap/msg/dds_node.h"
#include "densemap/ros2/sensor_pose.h"
#include "densemap/ros2/service_framing.h"
#include "densemap/server/latency_window.h"
#include "densemap/server/map_service.h"
#include "densemap/server/ros2_edge/ros2_wire.h"

namespace densemap::server::ros2_edge {

struct Ros2EdgeOptions {
  bool enabled = false;  ///< --ros2
  bool only = false;     ///< --ros2-only: no native densemap topics
  std::string node_name = "octomap_server";
  /// DDS-Security for the ROS 2 participant: an SROS2 enclave (from the fleet's keystore, or
  /// tools/make-security.sh's server folder). Empty: the server's --security-dir.
  std::string security_dir;
  ros2::FrameOptions frames{"/cloud_in", "map", "base_footprint", ""};
  /// The pose topic's type: "odometry" (nav_msgs/Odometry) or "pose_stamped" (geometry_msgs/PoseStamped).
  std::string pose_type = "odometry";
  /// A cloud whose transform has not arrived waits this long, then is dropped and counted.
  double tf_timeout_s = 1.0;
  /// Clouds waiting for TF at most (tf2 message filter's queue; octomap_server uses 5); the oldest goes.
  std::size_t tf_queue = 5;
  /// Map topics transient local (late subscribers get the last map), as octomap_server's `latch`.
  bool latch = false;
  /// Seconds between map publications (0: whenever the map changed, checked every 0.1 s).
  double map_publish_period_s = 1.0;
  double occupancy_min_z = -1e6, occupancy_max_z = 1e6;    ///< projected_map's height band
  double pointcloud_min_z = -1e6, pointcloud_max_z = 1e6;  ///< points outside are not inserted
  std::string params_file;  ///< an octomap_server parameters YAML (octomap_params.h)
  /// The ROS 2 distribution whose ros_discovery_info layout the edge publishes (Gid of 24 bytes in Humble
  /// and Iron, 16 in Jazzy, under one type name): "humble" or "jazzy".
  std::string ros_distribution = "humble";
};

/// What the edge did with what it received (besides the service's own per-robot counters).
struct Ros2Counters {
  std::uint64_t clouds_received = 0;
  std::uint64_t clouds_submitted = 0;
  std::uint64_t clouds_undecodable = 0;    ///< bad CDR or a layout that cannot be read
  std::uint64_t clouds_waited_out = 0;     ///< no transform within tf_timeout_s
  std::uint64_t clouds_queue_dropped = 0;  ///< pushed out of a full TF queue
  std::uint64_t tf_refused = 0;            ///< transforms refused (NaN, bad quaternion, loop, ...)
  std::uint64_t tf_undecodable = 0;        ///< TF / pose samples that did not decode
  std::uint64_t service_requests = 0;
  std::uint64_t service_requests_header = 0;  ///< in rmw_cyclonedds' framing (a header in the payload)
  std::uint64_t service_refused = 0;          ///< requests that fit neither framing: never executed
  std::uint64_t replies_unmatched = 0;        ///< replies sent before the client's reader was matched
  std::uint64_t maps_published = 0;
  LatencySummary tf_wait_ms;  ///< from arrival to the transform, per submitted cloud
};

class Ros2Edge {
 public:
  /// Creates its own DDS participant (named after the node) on `dds`'s domain and starts. Throws
  /// msg::DdsError or std::invalid_argument naming the option.
  Ros2Edge(MapService& service, const Ros2EdgeOptions& options, const msg::DdsOptions& dds);
  ~Ros2Edge();
  Ros2Edge(const Ros2Edge&) = delete;
  Ros2Edge& operator=(const Ros2Edge&) = delete;

  /// Stops taking clouds and requests, stops the threads; idempotent. Clouds still waiting are dropped.
  void stop();
  Ros2Counters counters() const;
  /// Publishers of clouds and of TF (or poses) this edge's readers have matched. Matching is not
  /// symmetric: a publisher may see the edge before the edge sees it, and what it sends until then is lost.
  std::size_t matchedCloudPublishers() const;
  std::size_t matchedPosePublishers() const;
  /// The fewest subscribers any of the four map topics has matched (a volatile subscriber gets only the
  /// publications after its match, which the edge sees a moment after the subscriber does).
  std::size_t matchedMapSubscribers() const;

 private:
  class Listener;
  class VendorListener;
  struct Pending {
    ReceivedCloud cloud;
    std::chrono::steady_clock::time_point arrived;
    std::int64_t source_ns = 0;    ///< when the node wrote it (DDS source timestamp, system clock)
    std::int64_t received_ns = 0;  ///< when the edge took it
  };
  struct Service;
  void takeTf(eprosima::fastdds::dds::DataReader* reader, bool is_static);
  void takePoses();
  void intakeLoop();
  void placeWaiting();
  void publishLoop();
  void serviceLoop();
  void publishMaps(bool force);
  bool tryPlace(Pending& p, std::string& why);
  void handle(Service& s);
  void publishDiscoveryInfo();
  void refuseRequest(const Service& s, ros2::ServiceFraming framing, const std::string& why);

  MapService& service_;
  Ros2EdgeOptions options_;
  std::string pose_type_;
  std::unique_ptr<Listener> listener_;
  std::unique_ptr<VendorListener> vendors_;  // before node_: the node holds it as its participant listener
  std::unique_ptr<msg::DdsNode> node_;
  eprosima::fastdds::dds::DataWriter* discovery_info_writer_ = nullptr;
  eprosima::fastdds::dds::DataReader* cloud_reader_ = nullptr;
  eprosima::fastdds::dds::DataReader* tf_reader_ = nullptr;
  eprosima::fastdds::dds::DataReader* tf_static_reader_ = nullptr;
  eprosima::fastdds::dds::DataReader* pose_reader_ = nullptr;
  eprosima::fastdds::dds::DataWriter* binary_writer_ = nullptr;
  eprosima::fastdds::dds::DataWriter* full_writer_ = nullptr;
  eprosima::fastdds::dds::DataWriter* projected_writer_ = nullptr;
  eprosima::fastdds::dds::DataWriter* centres_writer_ = nullptr;
  std::vector<std::unique_ptr<Service>> services_;

  mutable std::mutex tf_mutex_;
  ros2::TfBuffer tf_;
  mutable std::mutex mutex_;  // counters, wake-ups
  std::condition_variable wake_;
  std::deque<Pending> pending_;  // the intake thread's: clouds waiting for TF
  Ros2Counters counters_;
  LatencyWindow tf_wait_;
  std::uint64_t next_seq_ = 0;
  std::uint64_t published_version_ = std::numeric_limits<std::uint64_t>::max();
  std::atomic<bool> running_{true};
  std::thread intake_thread_, publish_thread_, service_thread_;
  std::mutex stop_mutex_;
  bool stopped_ = false;
};

}  // namespace densemap::server::ros2_edge
