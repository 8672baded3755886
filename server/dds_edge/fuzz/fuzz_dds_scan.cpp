// libFuzzer target for a received scan: the DDS decoder (fastddsgen's ScanPubSubType), the edge's
// conversion (server/dds_edge/src/wire.cpp) and the service's checks (server/src/scan_validator.cpp). A
// scan the checks accept has only finite points and a rigid pose; nothing may crash on the way.
#include <cmath>
#include <cstdlib>
#include <string>

#include "cdr_sample.h"
#include "densemap/msg/wire_types.h"
#include "densemap/server/dds_edge/wire.h"
#include "densemap/server/scan_validator.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  densemap::msg::Scan m;
  if (!decodeSample<densemap::msg::ScanPubSubType>(data, size, m)) return 0;
  std::string why;
  auto job = densemap::server::dds_edge::toScanJob(m, why);
  if (!why.empty()) return 0;
  densemap::server::ScanLimits limits;
  limits.max_points = 100'000;
  const densemap::geometry::KeyConverter conv(0.2);
  if (!densemap::server::validateScan(job, limits, conv).empty()) return 0;
  if (job.scan.points.size() > limits.max_points) std::abort();
  for (const auto& p : job.scan.points)
    if (!p.allFinite()) std::abort();
  const Eigen::Matrix3d r = job.scan.pose.linear();
  if (!job.scan.pose.matrix().allFinite() || (r * r.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-6)
    std::abort();
  return 0;
}
