// Joining a server with a participant that is made again when a secure join stalls: Fast DDS 2.9's secure
// discovery now and then never matches one participant with the server (no more than that participant:
// the server goes on matching others), and a new participant, with a new GUID, authenticates afresh. CI saw
// it for a robot and, once, for a query client; so every program that joins a server (robots, query and
// admin clients) joins through here.
#pragma once

#include <chrono>
#include <functional>
#include <string>

#include "densemap/cli/option_table.h"

namespace densemap::client {

/// Appended to a secure client's joinState(): why a secure participant may see no server at all.
inline constexpr const char* kUnauthenticatedHint =
    " (secure: a server that did not authenticate this identity matches nothing; its log names each "
    "refused participant)";

struct ServerJoin {
  bool joined = false;
  int rejoins = 0;    ///< participants replaced before the one that joined (or the last one)
  std::string state;  ///< joinState() of the last participant's client when not joined
};

/// What joinServer waits on, for one participant: its client's waitForServer and joinState.
struct JoinTarget {
  std::function<bool(std::chrono::milliseconds)> wait_for_server;
  std::function<std::string()> state;
};

/// Waits until the server answers `target()` (its wait_for_server), at most `timeout` in all. Each time
/// `attempt` passes unmatched, `rejoin()` replaces the participant and its client (both made anew by the
/// caller) and the wait goes on with the new one. `attempt` >= `timeout`: never replaced.
ServerJoin joinServerWith(const std::function<JoinTarget()>& target, const std::function<void()>& rejoin,
                          std::chrono::milliseconds timeout, std::chrono::milliseconds attempt);

/// The same for `client()` returning a ScanPublisher, QueryClient or AdminClient (anything with
/// waitForServer(milliseconds) and joinState()); called again after each rejoin.
template <class GetClient>
ServerJoin joinServer(GetClient&& client, const std::function<void()>& rejoin,
                      std::chrono::milliseconds timeout, std::chrono::milliseconds attempt) {
  return joinServerWith(
      [&client] {
        auto& c = client();
        return JoinTarget{[&c](std::chrono::milliseconds t) { return c.waitForServer(t); },
                          [&c] { return c.joinState(); }};
      },
      rejoin, timeout, attempt);
}

/// `--rejoin-after` and `--secure-join-wait`, shared by the programs that join a server.
struct JoinOptions {
  double rejoin_after_s = 20.0;
  double secure_join_wait_s = 60.0;
  /// The timeout for joinServer: in secure mode the longer of `program_wait` (the program's own wait for
  /// the server) and secure_join_wait_s, so that a stalled join has room for new participants; else
  /// `program_wait`.
  std::chrono::milliseconds wait(bool secure, std::chrono::milliseconds program_wait) const;
  /// The attempt for joinServer: rejoin_after_s in secure mode, else `timeout` (a plain participant has no
  /// handshake to stall, so it is never replaced).
  std::chrono::milliseconds attempt(bool secure, std::chrono::milliseconds timeout) const;
};
cli::OptionTable joinOptions(JoinOptions& options);

}  // namespace densemap::client
