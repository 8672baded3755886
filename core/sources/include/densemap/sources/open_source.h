// Any scan source by its specification: the one place that knows every reader, the simulator and the
// ROS 2 bags, so io (the files and the simulator) and ros2 (the bags) need not know each other.
#pragma once

#include <memory>
#include <string>

#include "densemap/io/scan_source.h"
#include "densemap/ros2/sensor_pose.h"

namespace densemap::sources {

/// How a source treats what is not there, and (ROS 2 bags) which clouds it reads in which frame.
struct OpenOptions {
  /// Map the scans a numbered sequence holds when some are missing (by default a gap is an error).
  bool allow_gaps = false;
  /// ROS 2 bags: which cloud topic, and the frames its poses are resolved in.
  ros2::FrameOptions frames;
};

/// Opens a source from a specification:
///  - "sim" or "sim:key=value,..." — the built-in LiDAR simulator (see LidarSimulatorOptions);
///  - a directory with clouds/ and poses/ — sequence directory;
///  - a directory with velodyne/ and poses.txt — KITTI odometry layout;
///  - a directory of <name>_<k>.pcd files, or one .pcd — world-frame PCD with the VIEWPOINT as origin;
///  - a .graph file — OctoMap scan graph;
///  - a .mcap or .db3 file, or a rosbag2 directory — a ROS 2 bag (options.frames).
/// Throws io::SourceError naming what is wrong.
[[nodiscard]] std::unique_ptr<io::ScanSource> openSource(const std::string& spec, const OpenOptions& options = {});

}  // namespace densemap::sources
