#include "densemap/server/ros2_edge/ros2_wire.h"

#include <cmath>

#include "densemap/map/map_file.h"
#include "densemap/map/map_projection.h"
#include "densemap/ros2/message_codec.h"

namespace densemap::server::ros2_edge {

std::optional<ReceivedCloud> decodeCloud(std::span<const std::uint8_t> sample, std::string& why) {
  try {
    const ros2::PointCloud2 c = ros2::decodePointCloud2(sample);
    return ReceivedCloud{c.header, ros2::cloudPoints(c)};
  } catch (const ros2::DecodeError& e) {
    why = e.what();
    return std::nullopt;
  }
}

ScanJob toScanJob(ReceivedCloud cloud, const ros2::SensorPose& pose, const std::string& robot_id,
                  std::uint64_t seq, double min_z, double max_z) {
  ScanJob job;
  job.robot_id = robot_id;
  job.seq = seq;
  job.position = pose.position;
  job.quaternion = pose.wxyz;
  job.scan.frame = io::PointFrame::kSensor;
  job.scan.nonfinite_points = cloud.points.nonfinite_points;
  job.scan.points = std::move(cloud.points.points);
  if (std::isfinite(min_z) || std::isfinite(max_z)) {
    const Eigen::Isometry3d world = io::poseFromQuaternion(pose.position, pose.wxyz);
    std::erase_if(job.scan.points, [&](const geometry::Vec3f& p) {
      const double z = (world * p.cast<double>()).z();
      return z < min_z || z > max_z;
    });
  }
  return job;
}

std::vector<std::uint8_t> octomapMessage(const map::OccupancyMap& map, bool binary,
                                         const ros2::Header& header) {
  ros2::Octomap m;
  m.header = header;
  m.binary = binary;
  m.id = "OcTree";
  m.resolution = map.resolution();
  const std::string data =
      map::octomapMessageData(map, binary ? map::OctomapFormat::kBinary : map::OctomapFormat::kFull);
  m.data.assign(data.begin(), data.end());
  return ros2::encode(m);
}

std::vector<std::uint8_t> projectedMapMessage(const map::OccupancyMap& map, double min_z, double max_z,
                                              const ros2::Header& header) {
  map::ProjectedGrid g = map::projectToGrid(map, min_z, max_z);
  ros2::OccupancyGrid m;
  m.header = header;
  m.map_load_time = header.stamp;
  m.resolution = static_cast<float>(g.resolution);
  m.width = g.width;
  m.height = g.height;
  m.origin_position = {g.origin_x, g.origin_y, 0.0};
  m.data = std::move(g.cells);
  return ros2::encode(m);
}

std::vector<std::uint8_t> occupiedCentresMessage(const map::OccupancyMap& map, const ros2::Header& header) {
  std::vector<std::uint8_t> storage;
  return ros2::encode(ros2::makeXyzCloud(map::occupiedCentres(map), header, storage));
}

std::optional<ClearBoxCommand> toClearBox(std::span<const std::uint8_t> request, std::string& why) {
  try {
    const ros2::BoundingBox b = ros2::decodeBoundingBoxRequest(request);
    ClearBoxCommand c;
    c.min = Vec3f(static_cast<float>(b.min[0]), static_cast<float>(b.min[1]), static_cast<float>(b.min[2]));
    c.max = Vec3f(static_cast<float>(b.max[0]), static_cast<float>(b.max[1]), static_cast<float>(b.max[2]));
    return c;  // the service checks the box (finite, ordered)
  } catch (const ros2::DecodeError& e) {
    why = e.what();
    return std::nullopt;
  }
}

}  // namespace densemap::server::ros2_edge
