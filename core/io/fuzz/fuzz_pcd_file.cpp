// libFuzzer target for the PCD parser (core/io/src/pcd_file.cpp): any bytes parse or are refused with
// SourceError; whatever parses holds only finite points and a unit viewpoint quaternion.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "densemap/io/pcd_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const auto d = densemap::io::parsePcd({reinterpret_cast<const char*>(data), size}, "fuzz.pcd");
    for (const auto& p : d.points)
      if (!p.allFinite()) std::abort();
    if (!d.viewpoint.allFinite() || std::abs(d.viewpoint_orientation.norm() - 1.0) > 1e-9) std::abort();
  } catch (const densemap::io::SourceError&) {
  }
  return 0;
}
