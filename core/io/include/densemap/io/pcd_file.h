// PCD files (PCL's Point Cloud Data format, v0.7), parsed by our own code: PCL's reader crashes on a 0-byte
// file or a negative COUNT, zero-fills fields it cannot convert and trusts the POINTS a header claims.
// This one checks the header and the data length against the file before it allocates anything.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Geometry>

#include "densemap/io/scan.h"

namespace densemap::io {

struct PcdData {
  std::vector<Vec3f> points;  ///< finite points only
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();
  Eigen::Quaterniond viewpoint_orientation = Eigen::Quaterniond::Identity();
  std::size_t nonfinite_points = 0;  ///< points with a NaN/Inf coordinate (organised clouds), left out
};

/// Parses a PCD held in memory: x y z as float32 or float64 (COUNT 1), any further fields, DATA ascii,
/// binary or binary_compressed. Throws SourceError starting with `name` and naming the field or byte
/// that was wrong on anything it cannot represent exactly.
PcdData parsePcd(std::string_view bytes, const std::string& name);
/// Reads and parses a PCD file (see parsePcd); the file must be a regular file.
PcdData readPcd(const std::string& path);
/// Writes a binary PCD with x y z and the given viewpoint.
void writePcd(const std::string& path, const std::vector<Vec3f>& points,
              const Eigen::Vector3d& viewpoint = Eigen::Vector3d::Zero());

}  // namespace densemap::io
