// The system clock in nanoseconds: the clock scan stamps and publish-to-map latencies use (hosts are
// assumed NTP-synced). One definition for the service, the edges and the clients.
#pragma once

#include <chrono>
#include <cstdint>

namespace densemap::util {

inline std::int64_t wallClockNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace densemap::util
