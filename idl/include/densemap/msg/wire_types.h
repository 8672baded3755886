// densemap's wire types as C++ names them: the current version of each topic type without its version
// suffix (densemap.idl says why the names on the wire carry one). Include this, never the generated headers.
#pragma once

#include "densemap/msg/densemap.h"
#include "densemap/msg/densemapPubSubTypes.h"

namespace densemap::msg {

using Scan = Scan_v1;
using ScanPubSubType = Scan_v1PubSubType;
using ScanAck = ScanAck_v1;
using ScanAckPubSubType = ScanAck_v1PubSubType;
using RobotProgress = RobotProgress_v1;
using RobotProgressPubSubType = RobotProgress_v1PubSubType;
using QueryRequest = QueryRequest_v1;
using QueryRequestPubSubType = QueryRequest_v1PubSubType;
using QueryReply = QueryReply_v1;
using QueryReplyPubSubType = QueryReply_v1PubSubType;
using AdminRequest = AdminRequest_v1;
using AdminRequestPubSubType = AdminRequest_v1PubSubType;
using AdminReply = AdminReply_v1;
using AdminReplyPubSubType = AdminReply_v1PubSubType;
using ServerStatistics = ServerStatistics_v1;
using ServerStatisticsPubSubType = ServerStatistics_v1PubSubType;

}  // namespace densemap::msg
