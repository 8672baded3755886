#include "densemap/server/scan_validator.h"

#include <cmath>

#include <fmt/format.h>

namespace densemap::server {

std::string validateScan(ScanJob& job, const ScanLimits& limits, const geometry::KeyConverter& conv) {
  auto& points = job.scan.points;
  if (job.robot_id.empty()) return "the scan has no robot_id";
  if (points.empty()) return "empty scan (no points)";
  if (points.size() > limits.max_points) {
    return fmt::format("{} points is over the limit of {} (raise limits.max_points if this LiDAR needs it)",
                       points.size(), limits.max_points);
  }
  for (double v : job.position) {
    if (!std::isfinite(v)) return "the sensor position is not finite";
  }
  geometry::VoxelKey origin_key;
  const geometry::Vec3f origin(static_cast<float>(job.position[0]), static_cast<float>(job.position[1]),
                               static_cast<float>(job.position[2]));
  if (!conv.toKey(origin, origin_key)) {
    return fmt::format("the sensor position lies outside the map's key range (|coordinate| < {} m)",
                       conv.resolution() * geometry::kKeyCenter);
  }
  const auto& q = job.quaternion;
  for (double v : q) {
    if (!std::isfinite(v)) return "the sensor orientation quaternion is not finite";
  }
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (norm == 0.0) return "the sensor orientation quaternion is zero";
  if (std::abs(norm - 1.0) > limits.quaternion_tolerance) {
    return fmt::format(
        "the sensor orientation quaternion has norm {:.6f}; send a unit quaternion (w, x, y, z)", norm);
  }
  // Missing returns are often sent as NaN: drop non-finite points, keep the rest.
  std::size_t kept = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (points[i].allFinite()) points[kept++] = points[i];
  }
  job.points_rejected += static_cast<std::uint32_t>(points.size() - kept);
  points.resize(kept);
  if (points.empty()) return "no finite points in the scan";
  job.scan.pose = io::poseFromQuaternion(job.position, q);
  return {};
}

}  // namespace densemap::server
