// libFuzzer target for a received admin command: the DDS decoder (AdminRequestPubSubType) and the edge's
// conversion to a service Command, a refusal, or a ping (server/dds_edge/src/wire.cpp); refusals get a
// reply carrying the request's id.
#include <cstdlib>
#include <variant>

#include "cdr_sample.h"
#include "densemap/msg/wire_types.h"
#include "densemap/server/dds_edge/wire.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  densemap::msg::AdminRequest rq;
  if (!decodeSample<densemap::msg::AdminRequestPubSubType>(data, size, rq)) return 0;
  const auto converted = densemap::server::dds_edge::toCommand(rq);
  if (const auto* refused = std::get_if<densemap::server::CommandResult>(&converted)) {
    if (refused->status == densemap::server::Status::kOk) std::abort();
    const auto reply = densemap::server::dds_edge::toReply(rq, *refused);
    if (reply.request_id() != rq.request_id()) std::abort();
  }
  return 0;
}
