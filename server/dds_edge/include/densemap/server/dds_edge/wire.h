// Every conversion between densemap's DDS messages (idl/densemap.idl) and the service's own types, in
// one place: the only code in server/ that sees generated types, besides the DDS edge that calls it.
#pragma once

#include <optional>
#include <string>
#include <variant>

#include "densemap/msg/wire_types.h"
#include "densemap/server/command.h"
#include "densemap/server/durability/robot_progress.h"
#include "densemap/server/pipeline.h"
#include "densemap/server/query.h"
#include "densemap/server/scan_job.h"
#include "densemap/server/service_statistics.h"

namespace densemap::server::dds_edge {

/// The scan as the service takes it. An empty `why` when the message is well formed as a message
/// (points packed x y z); what the scan holds is checked by the service (validateScan).
ScanJob toScanJob(const msg::Scan& m, std::string& why);
msg::ScanAck toAck(const ScanJob& job, ScanOutcome outcome, const std::string& why);

/// The query a request asks, or the answer to a request that cannot be one (unknown kind or layer,
/// points not packed x y z).
std::variant<Query, Answer> toQuery(const msg::QueryRequest& rq);
/// Takes the answer by value: its arrays are moved into the reply (the query path's hot copy otherwise).
msg::QueryReply toReply(const msg::QueryRequest& rq, Answer answer);

/// The command a request asks, or its result when it cannot be one. ADMIN_PING gives std::monostate.
std::variant<std::monostate, Command, CommandResult> toCommand(const msg::AdminRequest& rq);
msg::AdminReply toReply(const msg::AdminRequest& rq, const CommandResult& result);

msg::QueryStatus toWire(Status s);
msg::MapStatistics toWire(const MapSummary& s);
msg::ServerStatistics toWire(const ServiceStatistics& s);
/// `only_robot`: that robot's part alone (its own progress topic); empty: every robot's (the operator's).
msg::RobotProgress toWire(const durability::RobotProgress& p, const std::string& server_id,
                          std::uint64_t incarnation, bool journal, const std::string& only_robot = "");
/// When the server that sent `m` started (its stamp minus its uptime, system clock ns); nullopt when the
/// stamp or uptime cannot be one (NaN, negative, beyond the clock's range). Another server's statistics
/// are read to tell which of two servers on the same topics started first.
std::optional<std::int64_t> serverStartNs(const msg::ServerStatistics& m);

}  // namespace densemap::server::dds_edge
