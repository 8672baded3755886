#include "densemap/io/scan_source.h"

#include <filesystem>

#include "densemap/io/kitti_odometry_source.h"
#include "densemap/io/lidar_simulator.h"
#include "densemap/io/ros_bag_source.h"
#include "densemap/io/scan_graph_source.h"
#include "densemap/io/sequence_directory_source.h"
#include "densemap/io/viewpoint_pcd_source.h"

namespace densemap::io {

namespace fs = std::filesystem;

std::unique_ptr<ScanSource> openSource(const std::string& spec, const SourceOptions& options) {
  if (spec == "sim" || spec.rfind("sim:", 0) == 0) {
    try {
      return std::make_unique<LidarSimulator>(
          LidarSimulatorOptions::parse(spec.size() > 4 ? spec.substr(4) : ""));
    } catch (const std::invalid_argument& e) {
      throw SourceError(e.what());
    }
  }
  if (!fs::exists(spec))
    throw SourceError(spec + ": no such file or directory (give a dataset path, or 'sim' for the simulator)");
  if (ros2::isBag(spec)) return std::make_unique<RosBagSource>(spec, options);
  if (fs::is_directory(spec)) {
    if (fs::is_directory(spec + "/clouds")) return std::make_unique<SequenceDirectorySource>(spec, options);
    if (fs::is_directory(spec + "/velodyne")) return std::make_unique<KittiOdometrySource>(spec, options);
    return std::make_unique<ViewpointPcdSource>(spec, options);
  }
  const std::string ext = fs::path(spec).extension().string();
  if (ext == ".graph") return std::make_unique<ScanGraphSource>(spec);
  if (ext == ".pcd") return std::make_unique<ViewpointPcdSource>(spec, options);
  throw SourceError(spec +
                    ": unknown source type (expected a directory, a .pcd, a .graph, a ROS 2 bag (.mcap, "
                    ".db3, rosbag2 directory), or 'sim')");
}

}  // namespace densemap::io
