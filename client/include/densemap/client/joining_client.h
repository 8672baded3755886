// A client on a participant of its own, both made again when a secure join stalls (server_join.h). What
// densemap-query joins through, and what a program of your own can use for one ScanPublisher,
// QueryClient or AdminClient: a new participant has a new GUID and authenticates afresh.
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <utility>

#include "densemap/client/server_join.h"
#include "densemap/msg/dds_node.h"

namespace densemap::client {

/// `Client(node, arg)` on a participant made from `dds`. The client is made by join() or client(), so
/// the participant can be used on its own first (for example for what a test expects to be refused).
template <class Client, class Arg>
class JoiningClient {
 public:
  /// `node`: a participant already made from `dds` to start with (null: one is made here).
  JoiningClient(msg::DdsOptions dds, Arg arg, std::unique_ptr<msg::DdsNode> node = nullptr)
      : dds_(std::move(dds)), arg_(std::move(arg)), node_(std::move(node)) {
    if (!node_) node_ = std::make_unique<msg::DdsNode>(dds_);
  }
  JoiningClient(const JoiningClient&) = delete;
  JoiningClient& operator=(const JoiningClient&) = delete;

  /// Waits up to `timeout` for the server to match the client; each `attempt` that passes unmatched
  /// replaces the participant and the client (joinServer). Use JoinOptions::attempt for `attempt`.
  [[nodiscard]] ServerJoin join(std::chrono::milliseconds timeout, std::chrono::milliseconds attempt,
                                const JoinContext* context = nullptr) {
    return joinServer([this]() -> Client& { return client(); }, [this] { remake(); }, timeout, attempt,
                      context);
  }

  Client& client() {
    if (!client_) client_.emplace(*node_, arg_);
    return *client_;
  }
  /// The current participant (a join may replace it: do not keep the reference across join()).
  msg::DdsNode& node() { return *node_; }
  /// Participants made so far: 1 plus the replacements.
  int participants() const { return participants_; }

 private:
  void remake() {
    client_.reset();
    node_.reset();
    node_ = std::make_unique<msg::DdsNode>(dds_);
    ++participants_;
    client_.emplace(*node_, arg_);
  }

  msg::DdsOptions dds_;
  Arg arg_;
  std::unique_ptr<msg::DdsNode> node_;
  std::optional<Client> client_;  // declared after node_: destroyed before its participant
  int participants_ = 1;
};

}  // namespace densemap::client
