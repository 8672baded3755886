#include "densemap/client/query_client.h"

namespace densemap::client {

QueryClient::QueryClient(msg::DdsNode& node, std::string client_id)
    : RequestClient(node, std::move(client_id), msg::kQueryRequestTopic, msg::kQueryReplyTopic, [] {
        msg::QueryRequest probe;  // an empty point query: answers at once, changes nothing
        probe.kind(msg::QUERY_POINTS);
        return probe;
      }()) {}

AdminClient::AdminClient(msg::DdsNode& node, std::string client_id)
    : RequestClient(node, std::move(client_id), msg::kAdminRequestTopic, msg::kAdminReplyTopic, [] {
        msg::AdminRequest probe;  // answered by the server's edge itself
        probe.kind(msg::ADMIN_PING);
        return probe;
      }()) {}

std::string clientIdOf(const msg::DdsNode& node, const std::string& plain, const std::string& suffix) {
  if (!node.secure()) return plain;
  return suffix.empty() ? node.identity().name : node.identity().name + "." + suffix;
}

msg::QueryRequest boxRequest(msg::QueryKind kind, const std::array<float, 3>& lo,
                             const std::array<float, 3>& hi) {
  msg::QueryRequest rq;
  rq.kind(kind);
  rq.box_min(lo);
  rq.box_max(hi);
  return rq;
}

msg::AdminRequest saveRequest(const std::string& name) {
  msg::AdminRequest rq;
  rq.kind(msg::ADMIN_SAVE);
  rq.name(name);
  return rq;
}

msg::AdminRequest loadRequest(const std::string& name) {
  msg::AdminRequest rq;
  rq.kind(msg::ADMIN_LOAD);
  rq.name(name);
  return rq;
}

msg::AdminRequest clearBoxRequest(const std::array<float, 3>& lo, const std::array<float, 3>& hi) {
  msg::AdminRequest rq;
  rq.kind(msg::ADMIN_CLEAR_BOX);
  rq.box_min(lo);
  rq.box_max(hi);
  return rq;
}

msg::AdminRequest resetRequest() {
  msg::AdminRequest rq;
  rq.kind(msg::ADMIN_RESET);
  return rq;
}

std::string toString(msg::QueryStatus s) {
  switch (s) {
    case msg::STATUS_OK:
      return "ok";
    case msg::STATUS_INVALID_ARGUMENT:
      return "invalid argument";
    case msg::STATUS_UNKNOWN_KIND:
      return "unknown query kind";
    case msg::STATUS_LAYER_UNAVAILABLE:
      return "layer unavailable";
    case msg::STATUS_FAILED:
      return "failed";
    case msg::STATUS_NOT_FOUND:
      return "not found";
    case msg::STATUS_UNAVAILABLE:
      return "unavailable";
    case msg::STATUS_BUSY:
      return "busy";
  }
  return "status " + std::to_string(static_cast<unsigned>(s));
}

std::string toString(msg::ScanOutcome o) {
  switch (o) {
    case msg::SCAN_APPLIED:
      return "applied";
    case msg::SCAN_REJECTED:
      return "rejected";
    case msg::SCAN_DROPPED:
      return "dropped";
    case msg::SCAN_DUPLICATE:
      return "duplicate";
  }
  return "outcome " + std::to_string(static_cast<unsigned>(o));
}

}  // namespace densemap::client
