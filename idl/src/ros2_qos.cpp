#include "densemap/msg/ros2_qos.h"

namespace densemap::msg {

namespace fdds = eprosima::fastdds::dds;

namespace {
template <class Q>
void apply(const ros2::Qos& in, Q& q) {
  q.reliability().kind = in.reliable ? fdds::RELIABLE_RELIABILITY_QOS : fdds::BEST_EFFORT_RELIABILITY_QOS;
  q.durability().kind =
      in.transient_local ? fdds::TRANSIENT_LOCAL_DURABILITY_QOS : fdds::VOLATILE_DURABILITY_QOS;
  q.history().kind = in.keep_all ? fdds::KEEP_ALL_HISTORY_QOS : fdds::KEEP_LAST_HISTORY_QOS;
  q.history().depth = static_cast<std::int32_t>(in.depth);
  // Unbounded ROS 2 messages (clouds of megabytes): allocate per sample, as rmw_fastrtps does.
  q.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
}
}  // namespace

fdds::DataWriterQos writerQos(const ros2::Qos& in) {
  fdds::DataWriterQos q = fdds::DATAWRITER_QOS_DEFAULT;
  apply(in, q);
  // XCDR1, what ROS 2 (Humble, Fast DDS 2.x) sends; readers accept it by default.
  q.representation().m_value.clear();
  q.representation().m_value.push_back(fdds::XCDR_DATA_REPRESENTATION);
  // Large clouds go out from Fast DDS's own thread, so a slow reader does not block the publisher.
  q.publish_mode().kind = fdds::ASYNCHRONOUS_PUBLISH_MODE;
  q.data_sharing().off();
  return q;
}

fdds::DataReaderQos readerQos(const ros2::Qos& in) {
  fdds::DataReaderQos q = fdds::DATAREADER_QOS_DEFAULT;
  apply(in, q);
  q.data_sharing().off();
  return q;
}

}  // namespace densemap::msg
