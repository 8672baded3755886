// Checks a received scan before it may touch the map. Whole-scan problems reject the scan (the map stays
// unchanged); single non-finite points are removed and counted, as LiDAR drivers mark missing returns so.
#pragma once

#include <cstddef>
#include <string>

#include "densemap/geometry/voxel_key.h"
#include "densemap/server/scan_job.h"
#include "densemap/server/stage_options.h"

namespace densemap::server {

/// Empty when the scan may be mapped (after removing non-finite points, counted in job.points_rejected, and
/// setting job.scan.pose from the checked pose); else why it is rejected. The one place a scan is checked
/// (the edges only convert); `conv` is the map's, whose key range the sensor must lie in.
std::string validateScan(ScanJob& job, const ScanLimits& limits, const geometry::KeyConverter& conv);

}  // namespace densemap::server
