// A DDS type that carries a sample's CDR bytes as they are, under any type name: how densemap speaks
// ROS 2 without generated code in the data path. The ROS 2 codec (core/ros2/message_codec.h) reads and
// writes the bytes; replay publishes recorded bytes unchanged. As rmw_fastrtps: no key, and no type
// information or type object sent (ROS 2 matches on names only).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

namespace densemap::msg {

struct RawSample {
  std::vector<std::uint8_t> bytes;  ///< encapsulation header included
};

class RawCdrType : public eprosima::fastdds::dds::TopicDataType {
 public:
  /// `dds_type_name` as rmw_fastrtps names it ("sensor_msgs::msg::dds_::PointCloud2_").
  explicit RawCdrType(const std::string& dds_type_name);
  bool serialize(void* data, eprosima::fastrtps::rtps::SerializedPayload_t* payload) override;
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload, void* data) override;
  std::function<std::uint32_t()> getSerializedSizeProvider(void* data) override;
  void* createData() override;
  void deleteData(void* data) override;
  bool getKey(void* data, eprosima::fastrtps::rtps::InstanceHandle_t* handle, bool force_md5) override;
};

eprosima::fastdds::dds::TypeSupport rawCdrType(const std::string& dds_type_name);

}  // namespace densemap::msg
