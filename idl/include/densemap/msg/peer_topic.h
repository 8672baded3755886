// A topic per peer: replies go to densemap/query/reply/<client_id>, a robot's scans to
// densemap/scans/<robot_id> and its acknowledgements to densemap/scan_acks/<robot_id>. DDS-Security
// permissions grant topics by name, so a topic per peer lets each identity read only its own answers and
// publish only its own scans (issue 21); and each peer receives only what is meant for it.
#pragma once

#include <optional>
#include <string>

namespace densemap::msg {

/// Empty when `id` can name a peer (and its topic): 1..63 of letters, digits, '_', '.', '-', starting with a
/// letter or digit; else why not. `what` names the kind of id in the message ("client", "robot").
std::string checkPeerId(const std::string& id, const char* what = "client");

/// `base_topic` + "/" + `peer_id`.
std::string peerTopicOf(const std::string& base_topic, const std::string& peer_id);

/// The peer whose topic `topic` is, when it is one under `base_topic` (both as on the wire).
std::optional<std::string> peerOfTopic(const std::string& base_topic, const std::string& topic);

}  // namespace densemap::msg
