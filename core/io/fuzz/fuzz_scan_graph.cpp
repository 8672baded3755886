// libFuzzer target for OctoMap .graph scan graphs (core/io/src/scan_graph_source.cpp): every count is
// checked against the bytes that remain, so no input allocates more than its own size allows.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "densemap/io/scan_graph_source.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const auto scans =
        densemap::io::parseScanGraph({reinterpret_cast<const char*>(data), size}, "fuzz.graph");
    std::size_t points = 0;
    for (const auto& s : scans) {
      points += s.points.size();
      if (!s.pose.matrix().allFinite()) std::abort();
    }
    if (points * 28 > size) std::abort();  // each point takes 28 bytes of the file
  } catch (const densemap::io::SourceError&) {
  }
  return 0;
}
