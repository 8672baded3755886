// How ROS 2 clouds are placed (bags and the edge), as options added to a table.
#pragma once

#include "densemap/options/option_table.h"
#include "densemap/ros2/sensor_pose.h"

namespace densemap::ros2 {

/// --cloud-topic, --frame-id, --base-frame-id, --pose-topic.
void addFrameOptions(options::OptionTable& table, FrameOptions& frames);

}  // namespace densemap::ros2
