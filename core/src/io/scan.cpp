#include "densemap/io/scan.h"

namespace densemap::io {

std::vector<Vec3f> Scan::worldPoints() const {
  if (frame == PointFrame::kWorld) return points;
  std::vector<Vec3f> out(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = (pose * points[i].cast<double>()).cast<float>();
  return out;
}

std::vector<Vec3f> Scan::sensorPoints() const {
  if (frame == PointFrame::kSensor) return points;
  const Eigen::Isometry3d inv = pose.inverse();
  std::vector<Vec3f> out(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = (inv * points[i].cast<double>()).cast<float>();
  return out;
}

}  // namespace densemap::io
