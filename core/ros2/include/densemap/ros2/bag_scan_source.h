// A ROS 2 bag (MCAP or rosbag2 sqlite3) as a scan source: the clouds of one PointCloud2 topic, each with
// its sensor pose resolved through TF (or a pose topic) exactly as the server's ROS 2 edge resolves it.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "densemap/io/scan_source.h"
#include "densemap/ros2/bag_reader.h"
#include "densemap/ros2/sensor_pose.h"

namespace densemap::ros2 {

/// How a bag becomes scans: which clouds, placed in which frame, and whether unplaceable ones are left out.
struct BagSourceOptions {
  bool allow_gaps = false;
  FrameOptions frames;
};

class BagScanSource : public io::ScanSource {
 public:
  /// Throws SourceError when the bag cannot be read, has no (or several, without --cloud-topic)
  /// PointCloud2 topics, or a cloud has no transform to the fixed frame (named, with the reason).
  BagScanSource(const std::string& path, const BagSourceOptions& options);
  std::size_t size() const override { return clouds_.size(); }
  io::Scan read(std::size_t i) const override;
  std::string describe() const override;

  const BagReader& bag() const { return *bag_; }

 private:
  struct Cloud {
    BagMessageRef ref;
    Eigen::Isometry3d pose;  ///< fixed <- cloud frame at the cloud's stamp
  };
  std::string path_;
  std::string topic_;
  std::unique_ptr<BagReader> bag_;
  std::vector<Cloud> clouds_;
};

}  // namespace densemap::ros2
