// libFuzzer target for octomap_server parameter files (server/ros2_edge/src/octomap_params.cpp): any text
// applies or is refused with std::invalid_argument; what applies leaves every option a value of its type.
#include <cstddef>
#include <cstdint>
#include <string>

#include "densemap/server/ros2_edge/octomap_params.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace densemap;
  map::MapOptions map;
  update::UpdateOptions update;
  server::ros2_edge::Ros2EdgeOptions ros2;
  try {
    server::ros2_edge::applyOctomapParamsText(std::string(reinterpret_cast<const char*>(data), size),
                                              "fuzz.yaml", "octomap_server", {&map, &update, &ros2},
                                              [](const std::string& flag) { return flag == "latch"; });
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
