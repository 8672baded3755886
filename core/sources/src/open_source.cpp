#include "densemap/sources/open_source.h"

#include <filesystem>

#include "densemap/io/kitti_odometry_source.h"
#include "densemap/io/lidar_simulator.h"
#include "densemap/io/scan_graph_source.h"
#include "densemap/io/sequence_directory_source.h"
#include "densemap/io/viewpoint_pcd_source.h"
#include "densemap/ros2/bag_scan_source.h"

namespace densemap::sources {

namespace fs = std::filesystem;
using io::KittiOdometrySource;
using io::LidarSimulator;
using io::LidarSimulatorOptions;
using io::ScanGraphSource;
using io::ScanSource;
using io::SequenceDirectorySource;
using io::SourceError;
using io::SourceOptions;
using io::ViewpointPcdSource;

std::unique_ptr<ScanSource> openSource(const std::string& spec, const OpenOptions& options) {
  const SourceOptions files{options.allow_gaps};
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
  if (ros2::isBag(spec)) return std::make_unique<ros2::BagScanSource>(spec, ros2::BagSourceOptions{options.allow_gaps, options.frames});
  if (fs::is_directory(spec)) {
    if (fs::is_directory(spec + "/clouds")) return std::make_unique<SequenceDirectorySource>(spec, files);
    if (fs::is_directory(spec + "/velodyne")) return std::make_unique<KittiOdometrySource>(spec, files);
    return std::make_unique<ViewpointPcdSource>(spec, files);
  }
  const std::string ext = fs::path(spec).extension().string();
  if (ext == ".graph") return std::make_unique<ScanGraphSource>(spec);
  if (ext == ".pcd") return std::make_unique<ViewpointPcdSource>(spec, files);
  throw SourceError(spec +
                    ": unknown source type (expected a directory, a .pcd, a .graph, a ROS 2 bag (.mcap, "
                    ".db3, rosbag2 directory), or 'sim')");
}

}  // namespace densemap::sources
