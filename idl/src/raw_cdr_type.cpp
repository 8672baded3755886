#include "densemap/msg/raw_cdr_type.h"

#include <cstring>
#include <memory>

namespace densemap::msg {

RawCdrType::RawCdrType(const std::string& dds_type_name) {
  setName(dds_type_name.c_str());
  // A first guess for preallocation only: samples are unbounded and the history policies are dynamic.
  m_typeSize = 4096;
  m_isGetKeyDefined = false;
  auto_fill_type_information(false);
  auto_fill_type_object(false);
}

bool RawCdrType::serialize(void* data, eprosima::fastrtps::rtps::SerializedPayload_t* payload) {
  const auto& s = *static_cast<RawSample*>(data);
  if (s.bytes.size() < 4 || s.bytes.size() > payload->max_size) return false;
  std::memcpy(payload->data, s.bytes.data(), s.bytes.size());
  payload->length = static_cast<std::uint32_t>(s.bytes.size());
  payload->encapsulation = s.bytes[1] == 0x01 ? CDR_LE : CDR_BE;
  return true;
}

bool RawCdrType::deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload, void* data) {
  auto& s = *static_cast<RawSample*>(data);
  s.bytes.assign(payload->data, payload->data + payload->length);
  return true;  // the codec checks the bytes, and counts what it refuses
}

std::function<std::uint32_t()> RawCdrType::getSerializedSizeProvider(void* data) {
  return [data] { return static_cast<std::uint32_t>(static_cast<RawSample*>(data)->bytes.size()); };
}

void* RawCdrType::createData() { return std::make_unique<RawSample>().release(); }

void RawCdrType::deleteData(void* data) { std::unique_ptr<RawSample>(static_cast<RawSample*>(data)).reset(); }

bool RawCdrType::getKey(void*, eprosima::fastrtps::rtps::InstanceHandle_t*, bool) { return false; }

eprosima::fastdds::dds::TypeSupport rawCdrType(const std::string& dds_type_name) {
  return eprosima::fastdds::dds::TypeSupport(std::make_unique<RawCdrType>(dds_type_name).release());
}

}  // namespace densemap::msg
