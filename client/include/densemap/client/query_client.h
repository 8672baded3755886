// The two request-reply clients of a densemap server: queries (reads, densemap/query/*) and admin
// commands (save, load, clear, reset; densemap/admin/*, which a permissions file may withhold).
#pragma once

#include <array>
#include <string>

#include "densemap/client/request_client.h"
#include "densemap/msg/wire_types.h"

namespace densemap::client {

class QueryClient : public RequestClient<msg::QueryRequest, msg::QueryReply, msg::QueryRequestPubSubType,
                                         msg::QueryReplyPubSubType> {
 public:
  QueryClient(msg::DdsNode& node, std::string client_id);
};

class AdminClient : public RequestClient<msg::AdminRequest, msg::AdminReply, msg::AdminRequestPubSubType,
                                         msg::AdminReplyPubSubType> {
 public:
  AdminClient(msg::DdsNode& node, std::string client_id);
};

/// The client id a program's client uses: in secure mode the identity's name (its permissions name that
/// reply topic), followed by ".<suffix>" when one process runs several clients; in plain mode `plain`.
std::string clientIdOf(const msg::DdsNode& node, const std::string& plain, const std::string& suffix = "");

/// A query with the box fields set.
msg::QueryRequest boxRequest(msg::QueryKind kind, const std::array<float, 3>& lo,
                             const std::array<float, 3>& hi);
/// Admin requests.
msg::AdminRequest saveRequest(const std::string& name);
msg::AdminRequest loadRequest(const std::string& name);
msg::AdminRequest clearBoxRequest(const std::array<float, 3>& lo, const std::array<float, 3>& hi);
msg::AdminRequest resetRequest();

std::string toString(msg::QueryStatus s);
std::string toString(msg::ScanOutcome o);

}  // namespace densemap::client
