#include "densemap/client/server_join.h"

#include <algorithm>

#include <spdlog/spdlog.h>

namespace densemap::client {

ServerJoin joinServer(const std::function<ScanPublisher&()>& publisher, const std::function<void()>& rejoin,
                      std::chrono::milliseconds timeout, std::chrono::milliseconds attempt) {
  using Clock = std::chrono::steady_clock;
  const auto give_up = Clock::now() + timeout;
  ServerJoin out;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(give_up - Clock::now());
    if (publisher().waitForServer(std::min(attempt, left))) {
      out.joined = true;
      return out;
    }
    out.state = publisher().joinState();
    if (Clock::now() >= give_up) return out;
    spdlog::warn(
        "the server has not matched this participant within {:.1f} s ({}): joining again with a new one",
        std::chrono::duration<double>(attempt).count(), out.state);
    rejoin();
    ++out.rejoins;
  }
}

}  // namespace densemap::client
