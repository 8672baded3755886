// A generated PubSubType whose decoder never throws. fastddsgen's deserialize lets Fast CDR's exceptions
// out (a sample whose encapsulation header is not CDR throws BadParamException from read_encapsulation),
// and Fast DDS calls it inside DataReader::take: one malformed sample from any participant on the domain
// would end the process. Here such a sample is refused (Fast DDS drops it) and counted.
#pragma once

#include <atomic>
#include <cstdint>

#include <fastdds/rtps/common/SerializedPayload.h>

namespace densemap::msg {

/// Samples refused because they did not decode, since the process started (every topic).
std::uint64_t undecodableSamples();
/// Counts one refused sample (called by CheckedType).
void countUndecodableSample();

template <class PubSubType>
class CheckedType : public PubSubType {
 public:
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload, void* data) override {
    try {
      if (PubSubType::deserialize(payload, data)) return true;
    } catch (...) {  // Fast CDR's exceptions do not share a std:: base
    }
    countUndecodableSample();
    return false;
  }
};

}  // namespace densemap::msg
