// libFuzzer target for the .bt/.ot parser (core/map/src/octomap_file.cpp) and the grid loader on top of
// it: any bytes either load as a map or are refused with MapFileError; nothing else may happen. The octree
// backend is left out here: it hands accepted bytes to OctoMap's reader (whose build is not instrumented).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "densemap/map/map_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  densemap::map::MapLoadLimits limits;
  limits.max_cells = 1u << 20;  // keeps each input fast; the limit itself is what is tested
  try {
    const auto m = densemap::map::decodeMap(bytes, {"grid", 0.2, {}}, limits);
    if (m->knownCells() > limits.max_cells) std::abort();  // the limit did not hold
  } catch (const densemap::map::MapFileError&) {
    // refused with a message: fine
  }
  return 0;
}
