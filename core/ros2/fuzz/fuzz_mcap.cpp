// libFuzzer target for the MCAP reader (core/ros2/src/mcap_reader.cpp): any bytes index or are refused
// with BagError; every indexed message can then be read.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "densemap/ros2/mcap_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    densemap::ros2::McapReader r(std::vector<std::uint8_t>(data, data + size), "fuzz.mcap");
    for (const auto& m : r.messages()) r.readMessage(m);
  } catch (const densemap::ros2::BagError&) {
  }
  return 0;
}
