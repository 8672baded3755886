// libFuzzer target for another server's statistics as densemap-server reads them to find a second server
// on its topics, and the robot progress robots read: the DDS decoder (ServerStatisticsPubSubType) and
// serverStartNs (wire.cpp), whose arithmetic must stay defined whatever the stamp and uptime say.
#include <cstdlib>

#include "cdr_sample.h"
#include "densemap/msg/wire_types.h"
#include "densemap/server/dds_edge/wire.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // The server's robot progress, which every robot reads when it (re)connects, through the same decoder.
  densemap::msg::RobotProgress progress;
  (void)decodeSample<densemap::msg::RobotProgressPubSubType>(data, size, progress);
  densemap::msg::ServerStatistics m;
  if (!decodeSample<densemap::msg::ServerStatisticsPubSubType>(data, size, m)) return 0;
  if (const auto start = densemap::server::dds_edge::serverStartNs(m); start && *start > m.stamp_ns())
    std::abort();
  return 0;
}
