// An octomap_server parameters file (ROS 2 YAML: <node>: ros__parameters: ...) applied to densemap's
// options, so a team's existing configuration works unchanged. Parameters densemap does not implement
// (ground filtering, colours, ...) are named in a warning, never silently dropped.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "densemap/map/map_factory.h"
#include "densemap/server/ros2_edge/ros2_edge.h"
#include "densemap/update/update_engine.h"

namespace densemap::server::ros2_edge {

struct OctomapParamTargets {
  map::MapOptions* map = nullptr;
  update::UpdateOptions* update = nullptr;
  Ros2EdgeOptions* ros2 = nullptr;
};

/// Reads `path` (the section for `node_name`, "/<node_name>" or "/**") and sets each parameter's option,
/// unless `given(flag)` says its flag was on the command line. Returns the parameters it ignored, with
/// why. Throws std::invalid_argument naming the file and parameter (unreadable YAML, a wrong type).
std::vector<std::string> applyOctomapParams(const std::string& path, const std::string& node_name,
                                            const OctomapParamTargets& targets,
                                            const std::function<bool(const std::string& flag)>& given);

/// The same from YAML text (tests, the fuzz target); `name` names it in errors.
std::vector<std::string> applyOctomapParamsText(const std::string& yaml, const std::string& name,
                                                const std::string& node_name,
                                                const OctomapParamTargets& targets,
                                                const std::function<bool(const std::string& flag)>& given);

}  // namespace densemap::server::ros2_edge
