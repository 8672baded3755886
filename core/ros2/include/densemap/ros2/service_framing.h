// ROS 2 services as the two common middlewares carry them over DDS. Both put requests on
// rq/<service>Request and replies on rr/<service>Reply with the same types, but they pair a reply with its
// request differently:
// - rmw_fastrtps (and the DDS standard's RPC mapping): the request's sample identity (writer GUID and
//   sequence number), returned in the reply's related sample identity, outside the payload;
// - rmw_cyclonedds: a 16-byte header inside the payload before the request (the client's 8-byte id and an
//   8-byte sequence number), echoed before the reply (Cyclone's C API cannot set a related sample identity).
// A reader cannot tell the two apart from the bytes alone in general (an Empty request of 17 bytes could be
// either), so the edge decides by the requester's DDS vendor (RTPS participant discovery) and this module
// then reads the payload strictly in that form: a request that does not fit it exactly is refused.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace densemap::ros2 {

enum class ServiceFraming {
  kSampleIdentity,  ///< rmw_fastrtps, and every vendor not known to use a header
  kRequestHeader,   ///< rmw_cyclonedds: 16-byte header in the payload
};

/// RTPS vendor ids (the OMG's list) of the DDS implementations whose ROS 2 middleware frames services with
/// a header in the payload: Eclipse Cyclone DDS {0x01, 0x10}.
[[nodiscard]] ServiceFraming serviceFramingOfVendor(std::array<std::uint8_t, 2> vendor);
[[nodiscard]] const char* toString(ServiceFraming framing);

inline constexpr std::size_t kRequestHeaderBytes = 16;

/// A request with its framing taken off: `message` is a plain CDR sample of the request type (encapsulation
/// header first), as a kSampleIdentity request is on the wire.
struct FramedRequest {
  ServiceFraming framing = ServiceFraming::kSampleIdentity;
  std::array<std::uint8_t, kRequestHeaderBytes> header{};  ///< kRequestHeader: as received, to echo
  std::vector<std::uint8_t> message;
};

/// Takes the framing off `sample`; throws DecodeError when it is too short to hold it. Whether the rest is
/// exactly one request is for the request's decoder to say (CdrReader::expectEnd).
[[nodiscard]] FramedRequest unframeRequest(std::span<const std::uint8_t> sample, ServiceFraming framing);

/// The reply payload for `request`: `reply` (a plain CDR sample of the response type) as is, or with the
/// request's header before it.
[[nodiscard]] std::vector<std::uint8_t> frameReply(const FramedRequest& request,
                                                   std::vector<std::uint8_t> reply);

}  // namespace densemap::ros2
