#include "densemap/ros2/point_cloud_fields.h"

#include <cmath>
#include <cstring>
#include <optional>
#include <string>

#include "densemap/ros2/cdr.h"

namespace densemap::ros2 {

namespace {

struct Coordinate {
  std::uint32_t offset = 0;
  bool is_double = false;
};

Coordinate findCoordinate(const PointCloud2& cloud, const char* name) {
  const PointField* found = nullptr;
  for (const PointField& f : cloud.fields)
    if (f.name == name) {
      if (found) throw DecodeError(std::string("PointCloud2 has two fields named '") + name + "'");
      found = &f;
    }
  if (!found) {
    std::string names;
    for (const PointField& f : cloud.fields) names += (names.empty() ? "" : " ") + f.name;
    throw DecodeError(std::string("PointCloud2 has no field '") + name +
                      "' (fields: " + (names.empty() ? "none" : names) + ")");
  }
  if (found->datatype != PointField::kFloat32 && found->datatype != PointField::kFloat64)
    throw DecodeError(std::string("PointCloud2 field '") + name + "' has datatype " +
                      std::to_string(found->datatype) + "; densemap reads FLOAT32 (7) or FLOAT64 (8)");
  if (found->count < 1) throw DecodeError(std::string("PointCloud2 field '") + name + "' has count 0");
  const std::uint64_t size = found->datatype == PointField::kFloat64 ? 8 : 4;
  if (std::uint64_t{found->offset} + size > cloud.point_step)
    throw DecodeError(std::string("PointCloud2 field '") + name + "' at offset " +
                      std::to_string(found->offset) + " does not fit in point_step " +
                      std::to_string(cloud.point_step));
  return {found->offset, found->datatype == PointField::kFloat64};
}

float readCoordinate(const std::uint8_t* point, const Coordinate& c) {
  if (c.is_double) {
    double v;
    std::memcpy(&v, point + c.offset, sizeof v);
    return static_cast<float>(v);  // beyond float range: inf, counted as non-finite below
  }
  float v;
  std::memcpy(&v, point + c.offset, sizeof v);
  return v;
}

}  // namespace

CloudPoints cloudPoints(const PointCloud2& cloud) {
  if (cloud.is_bigendian)
    throw DecodeError("PointCloud2 is big-endian (is_bigendian true); densemap reads little-endian clouds");
  if (cloud.point_step == 0) throw DecodeError("PointCloud2 has point_step 0");
  const Coordinate x = findCoordinate(cloud, "x");
  const Coordinate y = findCoordinate(cloud, "y");
  const Coordinate z = findCoordinate(cloud, "z");
  const std::uint64_t row_bytes = std::uint64_t{cloud.width} * cloud.point_step;
  if (cloud.row_step < row_bytes)
    throw DecodeError("PointCloud2 row_step " + std::to_string(cloud.row_step) +
                      " is below width * point_step = " + std::to_string(cloud.width) + " * " +
                      std::to_string(cloud.point_step));
  const std::uint64_t needed = std::uint64_t{cloud.row_step} * cloud.height;
  if (cloud.data.size() < needed)
    throw DecodeError("PointCloud2 data holds " + std::to_string(cloud.data.size()) +
                      " bytes, row_step * height = " + std::to_string(cloud.row_step) + " * " +
                      std::to_string(cloud.height) + " = " + std::to_string(needed));
  CloudPoints out;
  // An empty cloud: nothing to walk (a claimed height of 4e9 rows of width 0 must not take seconds).
  if (cloud.width == 0 || cloud.height == 0) return out;
  out.points.reserve(std::size_t{cloud.width} * cloud.height);
  for (std::uint32_t r = 0; r < cloud.height; ++r) {
    const std::uint8_t* row = cloud.data.data() + std::size_t{r} * cloud.row_step;
    for (std::uint32_t c = 0; c < cloud.width; ++c) {
      const std::uint8_t* p = row + std::size_t{c} * cloud.point_step;
      const geometry::Vec3f v(readCoordinate(p, x), readCoordinate(p, y), readCoordinate(p, z));
      if (!std::isfinite(v.x()) || !std::isfinite(v.y()) || !std::isfinite(v.z())) {
        ++out.nonfinite_points;
        continue;
      }
      out.points.push_back(v);
    }
  }
  return out;
}

PointCloud2 makeXyzCloud(const std::vector<geometry::Vec3f>& points, const Header& header,
                         std::vector<std::uint8_t>& storage) {
  PointCloud2 c;
  c.header = header;
  c.height = 1;
  c.width = static_cast<std::uint32_t>(points.size());
  c.fields = {{"x", 0, PointField::kFloat32, 1},
              {"y", 4, PointField::kFloat32, 1},
              {"z", 8, PointField::kFloat32, 1}};
  c.point_step = 12;
  c.row_step = 12 * c.width;
  storage.resize(points.size() * 12);
  for (std::size_t i = 0; i < points.size(); ++i) std::memcpy(storage.data() + 12 * i, points[i].data(), 12);
  c.data = storage;
  c.is_dense = true;
  return c;
}

}  // namespace densemap::ros2
