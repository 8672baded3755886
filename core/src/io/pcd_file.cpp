// The only translation unit that includes PCL headers.
#include "densemap/io/pcd_file.h"

#include <filesystem>

#include <pcl/PCLPointCloud2.h>
#include <pcl/console/print.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

namespace densemap::io {

PcdData readPcd(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw SourceError(path + ": no such PCD file");
  // PCL prints its own errors; we report them ourselves with the file name.
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  pcl::PCLPointCloud2 blob;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  int version = 0;
  pcl::PCDReader reader;
  int rc = -1;
  try {
    rc = reader.read(path, blob, origin, orientation, version);
  } catch (const std::exception& e) {
    throw SourceError(path + ": unreadable PCD (" + e.what() + ")");
  }
  if (rc < 0) throw SourceError(path + ": corrupt or truncated PCD file (PCL could not parse it)");
  bool has[3] = {false, false, false};
  for (const auto& f : blob.fields) {
    if (f.name == "x") has[0] = true;
    if (f.name == "y") has[1] = true;
    if (f.name == "z") has[2] = true;
  }
  if (!has[0] || !has[1] || !has[2]) throw SourceError(path + ": PCD file has no x, y, z fields");
  const std::size_t expected = static_cast<std::size_t>(blob.width) * blob.height * blob.point_step;
  if (blob.data.size() < expected) throw SourceError(path + ": PCD data is truncated");
  pcl::PointCloud<pcl::PointXYZ> cloud;
  pcl::fromPCLPointCloud2(blob, cloud);
  PcdData out;
  out.points.reserve(cloud.size());
  for (const auto& p : cloud.points) out.points.emplace_back(p.x, p.y, p.z);
  out.viewpoint = origin.head<3>().cast<double>();
  out.viewpoint_orientation = orientation.cast<double>();
  return out;
}

void writePcd(const std::string& path, const std::vector<Vec3f>& points, const Eigen::Vector3d& viewpoint) {
  pcl::PointCloud<pcl::PointXYZ> cloud;
  cloud.reserve(points.size());
  for (const auto& p : points) cloud.push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  cloud.sensor_origin_ = Eigen::Vector4f(static_cast<float>(viewpoint.x()), static_cast<float>(viewpoint.y()),
                                         static_cast<float>(viewpoint.z()), 0.0f);
  if (pcl::io::savePCDFileBinary(path, cloud) < 0) throw SourceError(path + ": cannot write PCD file");
}

}  // namespace densemap::io
