// libFuzzer target for KITTI velodyne .bin scans (core/io/src/kitti_odometry_source.cpp).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "densemap/io/kitti_odometry_source.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const auto points = densemap::io::parseKittiBin({reinterpret_cast<const char*>(data), size}, "0.bin");
    if (points.size() != size / 16) std::abort();
    for (const auto& p : points)
      if (!p.allFinite()) std::abort();
  } catch (const densemap::io::SourceError&) {
  }
  return 0;
}
