// What the in-process service benchmarks share: a scan as the service's job, and elapsed milliseconds.
#pragma once

#include <chrono>
#include <cstdint>

#include "densemap/io/scan.h"
#include "densemap/server/scan_job.h"

namespace densemap::tools {

inline double msSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

/// The scan as robot "bench" sends it (sensor-frame points and the sensor pose), numbered `seq`.
inline server::ScanJob jobOf(const io::Scan& s, std::uint64_t seq) {
  server::ScanJob j;
  j.robot_id = "bench";
  j.seq = seq;
  const Eigen::Vector3d t = s.pose.translation();
  j.position = {t.x(), t.y(), t.z()};
  j.quaternion = io::quaternionOf(s.pose);
  j.scan.points = s.sensorPoints();
  return j;
}

}  // namespace densemap::tools
