// densemap-replay --ros2: plays as a ROS 2 robot would. A bag's messages go out unchanged (the recorded
// CDR bytes, on the recorded topics, with their DDS type names and recorded QoS, at the recorded timing),
// as `ros2 bag play` does; any other source's scans go out as PointCloud2 + TF.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "densemap/io/scan_source.h"
#include "densemap/msg/dds_node.h"
#include "densemap/ros2/bag_reader.h"

namespace densemap::client {

struct Ros2PlayOptions {
  double speed = 1.0;                ///< bags: recorded timing divided by this
  bool as_fast_as_possible = false;  ///< bags: no timing (--rate 0)
  double rate = 10.0;                ///< other sources: clouds per second
  double wait_s =
      60.0;  ///< for a subscriber to the clouds before starting, and for reliable delivery at the end
  std::string cloud_topic = "/cloud_in";  ///< other sources: where the clouds go
  std::string fixed_frame = "map";
  std::string sensor_frame = "lidar";
  /// Where it publishes, in words (client::joinContext's `where`), for what it says while it waits.
  std::string where;
};

struct Ros2PlayResult {
  std::size_t messages = 0;
  std::size_t clouds = 0;
  double seconds = 0;  ///< from the first message to the end (delivery waits included)
  std::chrono::steady_clock::time_point first_sent{};
  /// Set when no subscriber matched this cloud topic within wait_s: nothing was played.
  std::string unread_topic;
};

/// Plays every message of `bag` once a subscriber reads its clouds (unread_topic when none did within
/// wait_s).
Ros2PlayResult playBag(const ros2::BagReader& bag, msg::DdsNode& node, const Ros2PlayOptions& options);
/// Publishes `scans` as PointCloud2 (sensor frame) with a /tf transform fixed <- sensor at each stamp, once a
/// subscriber reads the clouds (unread_topic when none did within wait_s).
Ros2PlayResult playScans(const std::vector<io::Scan>& scans, msg::DdsNode& node,
                         const Ros2PlayOptions& options);

}  // namespace densemap::client
