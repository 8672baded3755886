// The option tables every program takes: each module's own (map, update, kernel layers, source, ROS 2
// frames) and logging, which is the programs' alone.
#pragma once

#include <string>

#include "densemap/dense/dense_option_table.h"
#include "densemap/map/map_option_table.h"
#include "densemap/options/option_table.h"
#include "densemap/ros2/frame_option_table.h"
#include "densemap/sources/source_option_table.h"
#include "densemap/update/update_option_table.h"

namespace densemap::cli {

/// --log-level.
[[nodiscard]] options::OptionTable loggingOptions(std::string& level);

}  // namespace densemap::cli
