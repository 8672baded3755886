// Joining a server with a participant that is made again when a secure join stalls: Fast DDS 2.9's secure
// discovery now and then never matches one participant with the server (no more than that participant:
// the server goes on matching others), and a new participant, with a new GUID, authenticates afresh. CI saw
// it for a robot and, once, for a query client; so every program that joins a server (robots, query and
// admin clients) joins through here.
#pragma once

#include <chrono>
#include <functional>
#include <string>

#include "densemap/msg/dds_node.h"
#include "densemap/options/option_table.h"

namespace densemap::client {

/// Appended to a secure client's joinState(): why a secure participant may see no server at all.
inline constexpr const char* kUnauthenticatedHint =
    " (secure: a server that did not authenticate this identity matches nothing; its log names each "
    "refused participant)";

/// What a program waits for, told to the user within 2 s and repeated every 10 s while it waits, and what
/// the error names when the wait ends with no server: a mistyped domain, --loopback on one side only, a
/// namespace or a refused identity must never look like a hang.
struct JoinContext {
  std::string what;   ///< e.g. "a densemap-server reading densemap/scans/robot_h0"
  std::string where;  ///< e.g. "DDS domain 0, no namespace, shared memory + UDP on every interface, plain"
  bool secure = false;
  std::string topic_namespace;  ///< the client's own, to tell a server on another namespace
};

/// The context of a client on `node` (made from `dds`) waiting for `what`.
[[nodiscard]] JoinContext joinContext(const msg::DdsOptions& dds, const msg::DdsNode& node, std::string what);

/// The error when no server matched within `waited`: what was awaited, where, the client's last state, and
/// the likely causes.
[[nodiscard]] std::string noServerMessage(const JoinContext& context, std::chrono::milliseconds waited,
                                          const std::string& state);

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
/// With a `context`, it logs what it waits for after 1 s unmatched and a progress line every 10 s.
[[nodiscard]] ServerJoin joinServerWith(const std::function<JoinTarget()>& target,
                                        const std::function<void()>& rejoin,
                                        std::chrono::milliseconds timeout, std::chrono::milliseconds attempt,
                                        const JoinContext* context = nullptr);

/// The same for `client()` returning a ScanPublisher, QueryClient or AdminClient (anything with
/// waitForServer(milliseconds) and joinState()); called again after each rejoin.
template <class GetClient>
[[nodiscard]] ServerJoin joinServer(GetClient&& client, const std::function<void()>& rejoin,
                                    std::chrono::milliseconds timeout, std::chrono::milliseconds attempt,
                                    const JoinContext* context = nullptr) {
  return joinServerWith(
      [&client] {
        auto& c = client();
        return JoinTarget{[&c](std::chrono::milliseconds t) { return c.waitForServer(t); },
                          [&c] { return c.joinState(); }};
      },
      rejoin, timeout, attempt, context);
}

/// `--wait` and `--rejoin-after`, shared by every program that joins a server (one meaning everywhere).
struct JoinOptions {
  double wait_s = 60.0;
  double rejoin_after_s = 20.0;
  [[nodiscard]] std::chrono::milliseconds wait() const;
  /// The attempt for joinServer: rejoin_after_s in secure mode, else the whole wait (a plain participant
  /// has no handshake to stall, so it is never replaced).
  [[nodiscard]] std::chrono::milliseconds attempt(bool secure) const;
};
options::OptionTable joinOptions(JoinOptions& options);

}  // namespace densemap::client
