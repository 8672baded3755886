#include "densemap/ros2/scan_messages.h"

#include <cstring>

#include "densemap/ros2/message_codec.h"

namespace densemap::ros2 {

ScanMessages scanMessages(const io::Scan& scan, std::int64_t stamp_ns, const std::string& fixed_frame,
                          const std::string& sensor_frame) {
  const std::vector<geometry::Vec3f> points = scan.sensorPoints();
  PointCloud2 c;
  c.header.stamp = Time::fromNanoseconds(stamp_ns);
  c.header.frame_id = sensor_frame;
  c.height = 1;
  c.width = static_cast<std::uint32_t>(points.size());
  c.fields = {{"x", 0, PointField::kFloat32, 1},
              {"y", 4, PointField::kFloat32, 1},
              {"z", 8, PointField::kFloat32, 1},
              {"intensity", 12, PointField::kFloat32, 1}};
  c.point_step = 16;
  c.row_step = 16 * c.width;
  std::vector<std::uint8_t> data(points.size() * 16, 0);
  for (std::size_t i = 0; i < points.size(); ++i) std::memcpy(data.data() + 16 * i, points[i].data(), 12);
  c.data = data;
  c.is_dense = true;

  TransformStamped t;
  t.header.stamp = c.header.stamp;
  t.header.frame_id = fixed_frame;
  t.child_frame_id = sensor_frame;
  const Eigen::Vector3d p = scan.pose.translation();
  const Eigen::Quaterniond q(scan.pose.rotation());
  t.translation = {p.x(), p.y(), p.z()};
  t.rotation = {q.x(), q.y(), q.z(), q.w()};
  return {encode(c), encode(TfMessage{{t}})};
}

}  // namespace densemap::ros2
