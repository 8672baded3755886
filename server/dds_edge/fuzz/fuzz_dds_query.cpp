// libFuzzer target for a received query: the DDS decoder (QueryRequestPubSubType) and the edge's
// conversion to a service Query or an error Answer (server/dds_edge/src/wire.cpp), then the reply built
// from that answer. Every request gets one of the two; nothing may crash.
#include <cstdlib>
#include <variant>

#include "cdr_sample.h"
#include "densemap/msg/wire_types.h"
#include "densemap/server/dds_edge/wire.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  densemap::msg::QueryRequest rq;
  if (!decodeSample<densemap::msg::QueryRequestPubSubType>(data, size, rq)) return 0;
  auto converted = densemap::server::dds_edge::toQuery(rq);
  if (auto* refused = std::get_if<densemap::server::Answer>(&converted)) {
    if (refused->status == densemap::server::Status::kOk || refused->message.empty()) std::abort();
    const auto reply = densemap::server::dds_edge::toReply(rq, std::move(*refused));
    if (reply.request_id() != rq.request_id()) std::abort();
  }
  return 0;
}
