// libFuzzer target for the ROS 2 PointCloud2 decoder (core/ros2/src/message_codec.cpp,
// point_cloud_fields.cpp): any bytes decode to finite points or are refused with DecodeError, and never
// more points than the data holds.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "densemap/ros2/message_codec.h"
#include "densemap/ros2/point_cloud_fields.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const densemap::ros2::PointCloud2 c = densemap::ros2::decodePointCloud2({data, size});
    const densemap::ros2::CloudPoints p = densemap::ros2::cloudPoints(c);
    for (const auto& v : p.points)
      if (!v.allFinite()) std::abort();
    if (p.points.size() + p.nonfinite_points != std::size_t{c.width} * c.height) std::abort();
    if (c.point_step > 0 && p.points.size() > c.data.size() / c.point_step) std::abort();
  } catch (const densemap::ros2::DecodeError&) {
  }
  return 0;
}
