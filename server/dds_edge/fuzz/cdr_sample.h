// Decodes fuzz bytes as a DDS sample of type T the way densemap's DataReaders do (the type's PubSubType,
// wrapped in msg::CheckedType, on a serialized payload, encapsulation header included); false when refused.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

#include <fastdds/rtps/common/SerializedPayload.h>

#include "densemap/msg/checked_type.h"

template <class PubSubType, class T>
bool decodeSample(const std::uint8_t* data, std::size_t size, T& out) {
  eprosima::fastrtps::rtps::SerializedPayload_t payload(static_cast<std::uint32_t>(size));
  if (size > 0) std::memcpy(payload.data, data, size);
  payload.length = static_cast<std::uint32_t>(size);
  densemap::msg::CheckedType<PubSubType> type;
  return type.deserialize(&payload, &out);
}
