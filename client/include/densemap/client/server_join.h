// Joining a server with a robot participant, made again when a secure join stalls: Fast DDS 2.9's secure
// discovery now and then never matches one participant with the server (no more than that participant:
// the server goes on matching others), and a new participant, with a new GUID, authenticates afresh.
#pragma once

#include <chrono>
#include <functional>
#include <string>

#include "densemap/client/scan_publisher.h"

namespace densemap::client {

struct ServerJoin {
  bool joined = false;
  int rejoins = 0;    ///< participants replaced before the one that joined (or the last one)
  std::string state;  ///< ScanPublisher::joinState() of the last participant when not joined
};

/// Waits until the server matches `publisher()` (ScanPublisher::waitForServer), at most `timeout` in all.
/// Each time `attempt` passes unmatched, `rejoin()` replaces the participant and its publisher (both made
/// anew by the caller) and the wait goes on with the new one. `attempt` >= `timeout`: never replaced.
ServerJoin joinServer(const std::function<ScanPublisher&()>& publisher, const std::function<void()>& rejoin,
                      std::chrono::milliseconds timeout, std::chrono::milliseconds attempt);

}  // namespace densemap::client
