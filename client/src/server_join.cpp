#include "densemap/client/server_join.h"

#include <algorithm>

#include <spdlog/spdlog.h>

namespace densemap::client {

ServerJoin joinServerWith(const std::function<JoinTarget()>& target, const std::function<void()>& rejoin,
                          std::chrono::milliseconds timeout, std::chrono::milliseconds attempt) {
  using Clock = std::chrono::steady_clock;
  const auto give_up = Clock::now() + timeout;
  ServerJoin out;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(give_up - Clock::now());
    const JoinTarget t = target();
    if (t.wait_for_server(std::min(attempt, left))) {
      out.joined = true;
      return out;
    }
    out.state = t.state();
    if (Clock::now() >= give_up) return out;
    spdlog::warn(
        "the server has not matched this participant within {:.1f} s ({}): joining again with a new one",
        std::chrono::duration<double>(attempt).count(), out.state);
    rejoin();
    ++out.rejoins;
  }
}

std::chrono::milliseconds JoinOptions::attempt(bool secure, std::chrono::milliseconds timeout) const {
  if (!secure || rejoin_after_s <= 0) return timeout;
  return std::chrono::milliseconds(static_cast<long>(rejoin_after_s * 1000));
}

std::chrono::milliseconds JoinOptions::wait(bool secure, std::chrono::milliseconds program_wait) const {
  if (!secure) return program_wait;
  return std::max(program_wait, std::chrono::milliseconds(static_cast<long>(secure_join_wait_s * 1000)));
}

cli::OptionTable joinOptions(JoinOptions& o) {
  cli::OptionTable t("Joining the server");
  t.add("rejoin-after", o.rejoin_after_s,
        "secure mode: a participant the server has not matched within this many seconds is replaced by a new "
        "one, until the wait for the server runs out (Fast DDS 2.9's secure discovery now and then never "
        "matches one participant; a new one authenticates afresh); 0: never")
      .range(0.0, 3600.0);
  t.add("secure-join-wait", o.secure_join_wait_s,
        "secure mode: seconds to wait in all for the server to match this program (authentication and the "
        "new participants of --rejoin-after take time a plain join does not); the program's own wait for "
        "the server applies when it is longer")
      .range(0.0, 3600.0);
  return t;
}

}  // namespace densemap::client
