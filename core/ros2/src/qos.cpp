#include "densemap/ros2/qos.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <stdexcept>

namespace densemap::ros2 {

std::optional<Qos> parseOfferedQos(const std::string& yaml) {
  if (yaml.empty()) return std::nullopt;
  try {
    const YAML::Node profiles = YAML::Load(yaml);
    if (!profiles.IsSequence() || profiles.size() == 0) return std::nullopt;
    const YAML::Node p = profiles[0];
    Qos q;
    // rmw enums: reliability 1 reliable, 2 best effort; durability 1 transient local, 2 volatile;
    // history 1 keep last, 2 keep all (0 system default, 3 unknown: keep last).
    if (p["reliability"]) q.reliable = p["reliability"].as<int>() != 2;
    if (p["durability"]) q.transient_local = p["durability"].as<int>() == 1;
    if (p["history"]) q.keep_all = p["history"].as<int>() == 2;
    if (p["depth"]) {
      const long depth = p["depth"].as<long>();
      q.depth = depth <= 0 ? 1u : static_cast<std::uint32_t>(std::min<long>(depth, 100000));
    }
    return q;
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument(std::string("offered_qos_profiles is not rosbag2 QoS YAML: ") + e.what());
  }
}

}  // namespace densemap::ros2
