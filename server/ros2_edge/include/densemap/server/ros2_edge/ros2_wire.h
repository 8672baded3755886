// Every conversion between ROS 2 messages (CDR bytes, through core/ros2's codec) and the service's own
// types, in one place: the ROS 2 edge calls these and sees nothing else of the wire.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "densemap/map/occupancy_map.h"
#include "densemap/ros2/point_cloud_fields.h"
#include "densemap/ros2/sensor_pose.h"
#include "densemap/server/command.h"
#include "densemap/server/scan_job.h"

namespace densemap::server::ros2_edge {

/// A PointCloud2 as received: its header and points (sensor frame).
struct ReceivedCloud {
  ros2::Header header;
  ros2::CloudPoints points;
};

/// The cloud in `sample`, or nullopt with `why` (undecodable CDR, or a layout densemap cannot read).
std::optional<ReceivedCloud> decodeCloud(std::span<const std::uint8_t> sample, std::string& why);

/// The scan the service takes for a cloud whose sensor pose is known. Points whose height in the fixed
/// frame lies outside [min_z, max_z] are left out, as octomap_server's pointcloud_min_z / max_z do.
ScanJob toScanJob(ReceivedCloud cloud, const ros2::SensorPose& pose, const std::string& robot_id,
                  std::uint64_t seq, double min_z, double max_z);

/// octomap_msgs/Octomap of the map (binary: each cell free or occupied; full: log-odds), as
/// octomap_msgs' binaryMapToMsg / fullMapToMsg fill it.
std::vector<std::uint8_t> octomapMessage(const map::OccupancyMap& map, bool binary,
                                         const ros2::Header& header);
/// nav_msgs/OccupancyGrid of the cells in [min_z, max_z] (map::projectToGrid).
std::vector<std::uint8_t> projectedMapMessage(const map::OccupancyMap& map, double min_z, double max_z,
                                              const ros2::Header& header);
/// sensor_msgs/PointCloud2 of the occupied cells' centres.
std::vector<std::uint8_t> occupiedCentresMessage(const map::OccupancyMap& map, const ros2::Header& header);

/// octomap_msgs/srv/BoundingBoxQuery's request as a clear-box command, or nullopt with `why`.
std::optional<ClearBoxCommand> toClearBox(std::span<const std::uint8_t> request, std::string& why);

}  // namespace densemap::server::ros2_edge
