// ROS 2 QoS profiles as plain values (what rclcpp's presets mean), and the QoS a bag recorded for a topic
// (rosbag2's offered_qos_profiles YAML), so replay offers what the robot offered.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace densemap::ros2 {

struct Qos {
  bool reliable = true;
  bool transient_local = false;
  bool keep_all = false;
  std::uint32_t depth = 10;

  /// rclcpp::SensorDataQoS: best effort, volatile, keep last 5 (what LiDAR drivers publish with).
  static Qos sensorData() { return {false, false, false, 5}; }
  /// rclcpp::QoS(10): reliable, volatile, keep last 10 (the default, and services').
  static Qos reliableDefault() { return {true, false, false, 10}; }
  /// tf2_ros::StaticBroadcasterQoS / StaticListenerQoS: reliable, transient local, keep last 1.
  static Qos tfStatic() { return {true, true, false, 1}; }
  /// tf2_ros::DynamicListenerQoS: reliable, volatile, keep last 100.
  static Qos tf() { return {true, false, false, 100}; }
  /// octomap_server's map topics with `latch`: transient local, keep last 1.
  static Qos latched() { return {true, true, false, 1}; }
};

/// The first profile of rosbag2's offered_qos_profiles (history, depth, reliability, durability as rmw's
/// enum values); nullopt for "" (not recorded). Throws std::invalid_argument for text that is not one.
std::optional<Qos> parseOfferedQos(const std::string& yaml);

}  // namespace densemap::ros2
