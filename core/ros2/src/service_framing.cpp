#include "densemap/ros2/service_framing.h"

#include <algorithm>
#include <cstring>

#include "densemap/ros2/cdr.h"

namespace densemap::ros2 {

namespace {
constexpr std::array<std::uint8_t, 2> kCycloneDdsVendor{0x01, 0x10};
constexpr std::size_t kEncapsulationBytes = 4;
}  // namespace

ServiceFraming serviceFramingOfVendor(std::array<std::uint8_t, 2> vendor) {
  return vendor == kCycloneDdsVendor ? ServiceFraming::kRequestHeader : ServiceFraming::kSampleIdentity;
}

const char* toString(ServiceFraming framing) {
  return framing == ServiceFraming::kRequestHeader ? "request header (rmw_cyclonedds)"
                                                   : "sample identity (rmw_fastrtps)";
}

FramedRequest unframeRequest(std::span<const std::uint8_t> sample, ServiceFraming framing) {
  FramedRequest r;
  r.framing = framing;
  if (framing == ServiceFraming::kSampleIdentity) {
    r.message.assign(sample.begin(), sample.end());
    return r;
  }
  if (sample.size() < kEncapsulationBytes + kRequestHeaderBytes) {
    throw DecodeError("request of " + std::to_string(sample.size()) + " bytes cannot hold rmw_cyclonedds' " +
                      std::to_string(kRequestHeaderBytes) + "-byte request header");
  }
  // The header is 16 bytes, so the request after it keeps its CDR alignment when the header is cut out.
  const auto header = sample.subspan(kEncapsulationBytes, kRequestHeaderBytes);
  std::copy(header.begin(), header.end(), r.header.begin());
  const auto request = sample.subspan(kEncapsulationBytes + kRequestHeaderBytes);
  r.message.resize(kEncapsulationBytes + request.size());
  std::memcpy(r.message.data(), sample.data(), kEncapsulationBytes);
  if (!request.empty()) std::memcpy(r.message.data() + kEncapsulationBytes, request.data(), request.size());
  return r;
}

std::vector<std::uint8_t> frameReply(const FramedRequest& request, std::vector<std::uint8_t> reply) {
  if (request.framing == ServiceFraming::kSampleIdentity || reply.size() < kEncapsulationBytes) return reply;
  std::vector<std::uint8_t> framed(reply.size() + kRequestHeaderBytes);
  std::memcpy(framed.data(), reply.data(), kEncapsulationBytes);
  std::memcpy(framed.data() + kEncapsulationBytes, request.header.data(), kRequestHeaderBytes);
  std::memcpy(framed.data() + kEncapsulationBytes + kRequestHeaderBytes, reply.data() + kEncapsulationBytes,
              reply.size() - kEncapsulationBytes);
  return framed;
}

}  // namespace densemap::ros2
