// The ROS 2 edge's options, declared once (flags, config keys, --help, config/server.toml).
#pragma once

#include "densemap/options/option_table.h"
#include "densemap/server/ros2_edge/ros2_edge.h"

namespace densemap::server::ros2_edge {

options::OptionTable ros2Options(Ros2EdgeOptions& options);

}  // namespace densemap::server::ros2_edge
