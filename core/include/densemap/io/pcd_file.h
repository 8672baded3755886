// PCD reading and writing through PCL, reduced to what the sources need.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "densemap/io/scan.h"

namespace densemap::io {

struct PcdData {
  std::vector<Vec3f> points;
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();
  Eigen::Quaterniond viewpoint_orientation = Eigen::Quaterniond::Identity();
};

/// Reads x, y, z (and the VIEWPOINT) of a PCD file; throws SourceError naming the file.
PcdData readPcd(const std::string& path);
/// Writes a binary PCD with x y z and the given viewpoint.
void writePcd(const std::string& path, const std::vector<Vec3f>& points,
              const Eigen::Vector3d& viewpoint = Eigen::Vector3d::Zero());

}  // namespace densemap::io
