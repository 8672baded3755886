// ROS 2 QoS (core/ros2/qos.h) as Fast DDS reader and writer QoS, the way rmw_fastrtps maps them: the one
// place the ROS 2 edge and replay --ros2 get their DDS QoS from.
#pragma once

#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

#include "densemap/ros2/qos.h"

namespace densemap::msg {

eprosima::fastdds::dds::DataWriterQos writerQos(const ros2::Qos& qos);
eprosima::fastdds::dds::DataReaderQos readerQos(const ros2::Qos& qos);

}  // namespace densemap::msg
