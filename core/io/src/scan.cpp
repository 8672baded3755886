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

Eigen::Isometry3d poseFromQuaternion(const std::array<double, 3>& position,
                                     const std::array<double, 4>& wxyz) {
  Eigen::Quaterniond q(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
  q.normalize();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = q.toRotationMatrix();
  pose.translation() = Eigen::Vector3d(position[0], position[1], position[2]);
  return pose;
}

std::array<double, 4> quaternionOf(const Eigen::Isometry3d& pose) {
  const Eigen::Quaterniond q(pose.rotation());
  return {q.w(), q.x(), q.y(), q.z()};
}

}  // namespace densemap::io
