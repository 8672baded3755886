// "Give me scan i": the one interface every reader and the simulator implement.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "densemap/io/scan.h"
#include "densemap/ros2/sensor_pose.h"

namespace densemap::io {

class ScanSource {
 public:
  virtual ~ScanSource() = default;
  virtual std::size_t size() const = 0;
  /// Throws SourceError (naming the file) on missing, corrupt or truncated data.
  virtual Scan read(std::size_t i) const = 0;
  /// A short human-readable description ("kitti00 sequence directory, 60 scans").
  virtual std::string describe() const = 0;
};

/// How a source treats what is not there.
struct SourceOptions {
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
std::unique_ptr<ScanSource> openSource(const std::string& spec, const SourceOptions& options = {});

}  // namespace densemap::io
